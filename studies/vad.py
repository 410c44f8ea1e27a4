"""Measure the voice-activity detectors and what the robot does with noise: ``python studies/vad.py [NOISE_DIR]``.

False alarms: every recorded noise file whole, and 3 s excerpts (the first two) of each. Misses: four TTS
sentences (four voices) mixed with every third noise file at 20, 10, 5 and 0 dB (fixed seeds).

``--pipeline`` also runs what ``siftom infer --audio`` does after the detector (cut to the speech,
recognise with the scene-biased decoder, infer) on every clip and excerpt the detector passes,
in two scenes (kitchen-cereal-v0, household-table-v0/3), and counts the clips that end in a
command: with any words taken as an instruction (as before) and with the nearness check
(``likelihood/nearness.py``: words near no command of the scene are no instruction). For speech
at 5 dB it counts the mixes heard as an instruction (each sentence in its own scene).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from siftom.speech.vad import detect_speech

SENTENCES = (("can you pass me the cereal", "flite-slt"), ("bring me three forks", "flite-rms"),
             ("i need the milk", "espeak-en-us+klatt"), ("could you grab the olive oil please", "espeak-es"))
SCENES = ("kitchen-cereal-v0", "household-table-v0/3")
SENTENCE_SCENE = ("kitchen-cereal-v0", "household-table-v0/3", "kitchen-cereal-v0", "kitchen-cereal-v0")
PIPELINE_SNR = 5


class _Robot:
    """What ``siftom infer --audio`` does after the detector, in one scene (engine and model cached)."""

    def __init__(self, scenario: str) -> None:
        from siftom.observer import observer_for
        from siftom.scenarios.base import get_scenario
        from siftom.settings import Settings

        sc = get_scenario(scenario)
        observer = observer_for(Settings.load(env={}))
        self.asr = observer.recogniser(sc.world, sc.verb)
        self.online = observer.model("full", "phonetic").online(sc.world, sc.start, sc.goals, sc.verb)
        for a in sc.actions:
            self.online.observe(a)

    def hear(self, x: Any, vad: Any) -> tuple[bool, bool, str]:
        """(words heard: a command before the nearness check, a command now, the 1-best)."""
        from siftom.speech.asr import DEFAULT_NBEST
        from siftom.speech.vad import trim

        if not vad.speech:
            return False, False, ""
        y = trim(x, vad)
        tr = self.asr.transcribe(y, nbest=DEFAULT_NBEST)
        if not tr.text:
            return False, False, ""
        post = self.online.posterior(tr.to_instruction(samples=y))
        return True, not post.evidence.get("no_instruction"), tr.text


def main(noise_dir: str | None = None, methods: tuple[str, ...] = ("silero", "spectral"),
         pipeline: bool = False) -> dict[str, Any]:
    """False alarms and misses per detector method (see module doc)."""
    from siftom.speech.audio import load_audio
    from siftom.speech.noise import RECORDED_NOISE_DIR, mix_at_snr
    from siftom.speech.tts import synthesize

    files = sorted(Path(noise_dir or RECORDED_NOISE_DIR).glob("*.wav"))
    noises = {f.stem: load_audio(f) for f in files}
    speech = [synthesize(text, voice) for text, voice in SENTENCES]
    robots = {sid: _Robot(sid) for sid in SCENES} if pipeline else {}
    out: dict[str, object] = {"noise_files": len(files)}
    for method in methods:
        clips: list[tuple[str, Any]] = []
        for name, x in noises.items():
            clips.append((name, x))
            for k in range(2):
                seg = x[k * 48_000:(k + 1) * 48_000]
                if len(seg) >= 16_000:
                    clips.append((f"{name}#{k}", seg))
        vads = {name: detect_speech(x, method=method) for name, x in clips}
        whole = [n for n in noises if vads[n].speech]
        alarms = [n for n, _x in clips if "#" in n and vads[n].speech]
        excerpts = sum("#" in n for n, _x in clips)
        heard: dict[str, list[int]] = {}
        mixes = []
        for i, sp in enumerate(speech):
            for j, f in enumerate(files[::3]):
                for snr in (20, 10, 5, 0):
                    mix = mix_at_snr(sp, noises[f.stem], snr, i * 100 + j)
                    r = detect_speech(mix, method=method)
                    cell = heard.setdefault(f"{snr} dB", [0, 0])
                    cell[0] += int(r.speech)
                    cell[1] += 1
                    if snr == PIPELINE_SNR:
                        mixes.append((i, mix, r))
        res: dict[str, object] = {
            "whole_clips_with_speech": f"{len(whole)}/{len(noises)}", "whole_clip_files": whole,
            "excerpts_with_speech": f"{len(alarms)}/{excerpts}", "excerpt_files": alarms,
            "speech_detected": {k: f"{a}/{n}" for k, (a, n) in heard.items()}}
        if pipeline:
            res["pipeline"] = _pipeline(clips, vads, mixes, robots)
        out[method] = res
    return out


def _pipeline(clips: list[tuple[str, Any]], vads: dict[str, Any], mixes: list[tuple[int, Any, Any]],
              robots: dict[str, _Robot]) -> dict[str, object]:
    """Commands from noise (whole clips, excerpts) and instructions heard in speech at 5 dB."""
    words: dict[str, list[str]] = {"whole": [], "excerpts": []}
    commands: dict[str, list[str]] = {"whole": [], "excerpts": []}
    for name, x in clips:
        if not vads[name].speech:
            continue
        part = "excerpts" if "#" in name else "whole"
        for sid, robot in robots.items():
            w, c, text = robot.hear(x, vads[name])
            if w:
                words[part].append(f"{name} @ {sid}: {text!r}")
            if c:
                commands[part].append(f"{name} @ {sid}: {text!r}")
    n_whole = sum("#" not in n for n, _x in clips) * len(robots)
    n_exc = sum("#" in n for n, _x in clips) * len(robots)
    said_before = said_now = 0
    for i, mix, vad in mixes:
        w, c, _text = robots[SENTENCE_SCENE[i]].hear(mix, vad)
        said_before += int(w)
        said_now += int(c)
    return {
        "noise_to_command_any_words": {"whole": f"{len(words['whole'])}/{n_whole}",
                                       "excerpts": f"{len(words['excerpts'])}/{n_exc}"},
        "noise_to_command_with_nearness": {"whole": f"{len(commands['whole'])}/{n_whole}",
                                           "excerpts": f"{len(commands['excerpts'])}/{n_exc}"},
        "noise_commands": commands["whole"] + commands["excerpts"],
        "noise_words": words["whole"] + words["excerpts"],
        f"speech_{PIPELINE_SNR}dB_instruction_any_words": f"{said_before}/{len(mixes)}",
        f"speech_{PIPELINE_SNR}dB_instruction_with_nearness": f"{said_now}/{len(mixes)}",
    }


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--pipeline"]  # [NOISE_DIR] [--pipeline]
    print(json.dumps(main(args[0] if args else None, pipeline="--pipeline" in sys.argv), indent=2))
