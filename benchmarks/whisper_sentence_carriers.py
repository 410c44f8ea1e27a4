"""Other Whisper carriers for clips whose 1-best holds no key word (research tool; not adopted).

For the ``sentence``-mode clips of a benchmarks/whisper_features.py dump: Whisper scores of
each wide command with (A) the first N-best hypothesis holding a key word as the carrier and (B)
the 1-best with the key phrase appended; then full-model accuracy per SNR for the shipped
closest-phrasing carrier, A, B and their log-sum with it (T_w = 3).

    python benchmarks/whisper_sentence_carriers.py DATASET DUMP.jsonl OUT.jsonl   # scores (~1 min)
    python benchmarks/whisper_sentence_carriers.py --report DUMP.jsonl OUT.jsonl
"""
# ruff: noqa
import json
import sys

import numpy as np
from scipy.special import logsumexp


def score():
    from siftom.likelihood.acoustic import key_phrases
    from siftom.world.commands import RobotCommand
    from siftom.speech.whisper_score import WhisperScorer
    from siftom.bench.stimuli import load_dataset
    from siftom.speech.audio import load_audio
    ds = load_dataset(sys.argv[1]); byid = {s.id: s for s in ds.stimuli}
    ws = WhisperScorer(pad_s=3.0, cpu_threads=1)
    out = open(sys.argv[3], "w")
    for line in open(sys.argv[2]):
        r = json.loads(line)
        if not r.get("speech") or r["mode"] != "sentence": continue
        cmds = [RobotCommand.parse(c) for c in r["cmds"]]
        keys = [key_phrases(c) for c in cmds]
        kw = {w for ks in keys for k, _ in ks for w in k.split()}
        x = load_audio(ds.root / byid[r["id"]].audio)
        wide = r["wide"]
        variants = {}
        # A: first N-best hypothesis with a key word as the carrier
        hyp = next((h for h in r["nbest"] if any(w in kw for w in h.split())), None)
        if hyp is not None:
            words = hyp.split(); idx = [i for i, w in enumerate(words) if w in kw]
            b, a = words[:idx[0]], words[idx[-1] + 1:]
            variants["A"] = [[(" ".join([*b, k, *a]), lp) for k, lp in keys[i]] for i in wide]
        # B: the 1-best with the key phrase appended at the end (object usually last)
        words = r["nbest"][0].split()
        variants["B"] = [[(" ".join([*words, k]), lp) for k, lp in keys[i]] for i in wide]
        rec = {"id": r["id"], "v": {}}
        enc = ws.encode(x)
        for name, texts in variants.items():
            uniq = list(dict.fromkeys(t for v in texts for t, _ in v))
            of = dict(zip(uniq, ws.score_encoded(enc, uniq).tolist()))
            rec["v"][name] = [[[of[t], lp] for t, lp in v] for v in texts]
        out.write(json.dumps(rec) + "\n"); out.flush()


def report():
    import collections
    rows = {json.loads(l)["id"]: json.loads(l) for l in open(sys.argv[2])}
    alt = {json.loads(l)["id"]: json.loads(l) for l in open(sys.argv[3])}
    acc = collections.defaultdict(list)
    for i, v in alt.items():
        r = rows[i]; ctx = np.array(r["ctx"]); corr = np.array(r["correct"]); phon = np.array(r["phon"])
        wide = np.array(r["wide"]); keep = np.array(r["keep"])
        def term(items_list):
            w = np.full(len(phon), -np.inf); w[wide] = [logsumexp([s + lp for s, lp in it]) for it in items_list]
            wk = np.full(len(w), w[keep].min()); wk[keep] = w[keep]; return wk
        base = term(r["w"]["3.0"])
        cands = {"siftom": phon, "closest": phon + base / 3}
        if "A" in v["v"]:
            cands["A"] = phon + term(v["v"]["A"]) / 3
            cands["A+closest"] = phon + np.logaddexp(term(v["v"]["A"]), base) / 3
        else:
            cands["A"] = cands["closest"]; cands["A+closest"] = cands["closest"]
        cands["B"] = phon + term(v["v"]["B"]) / 3
        cands["B+closest"] = phon + np.logaddexp(term(v["v"]["B"]), base) / 3
        for n, q in cands.items():
            ok = bool(corr[np.argmax(ctx + q)]); acc[(r["snr"], n)].append(ok); acc[("all", n)].append(ok)
    for snr in ["clean", "20 dB", "10 dB", "5 dB", "all"]:
        print(snr, len(acc[(snr, "siftom")]), {n: round(100*np.mean(acc[(snr, n)]), 1) for n in ["siftom","closest","A","A+closest","B","B+closest"]})


if __name__ == "__main__":
    if sys.argv[1] == "--report":
        report()
    else:
        score()
