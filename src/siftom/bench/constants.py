"""The modelling constants a user's results depend on, with the data each was chosen on.

:data:`CONSTANTS` is the registry behind ``docs/explanation/constants.md``: each entry names a
constant by where it lives (``module.NAME``, ``module.Class.field`` for a dataclass default, or
``module.callable(param)`` for a keyword default), says what it does, the set it was chosen on
(``not recorded`` where nothing in the repository says) and the command that refits it. The
value in the page is read by import (:func:`value_of`), never typed, so the page cannot drift
from the code: ``siftom bench pages --fill docs/explanation/constants.md`` rewrites it and
``tests/bench/test_generated_docs.py`` fails when the committed page differs.
"""

from __future__ import annotations

from collections.abc import Sequence

from siftom.bench.constant_refs import (
    MEASURED,
    NOT_RECORDED,
    ORIGINS,
    PAPER,
    SET,
    SILERO,
    TUNED,
    WHISPER,
    Constant,
    fmt,
    value_of,
)
from siftom.errors import SiftomError

__all__ = ["CONSTANTS", "MEASURED", "NOT_RECORDED", "ORIGINS", "PAPER", "SET", "SILERO", "TUNED", "WHISPER",
           "Constant", "constants_table", "fmt", "not_recorded", "value_of"]


S1 = "the seed-1 development sets (`--seed 1`, docs/benchmark.md)"
NOREC = NOT_RECORDED
NO_RECIPE = "no recipe ¹"
RESEARCH = "(research script of 0.1.0: `git show a8b08aa:benchmarks/NAME.py`)"

CONSTANTS: tuple[Constant, ...] = (
    # the model (docs/inference.md)
    Constant("siftom.inference.model.ModelConfig.betas",
             "grid of Boltzmann rationalities β the action likelihood is marginalised over (uniform prior)",
             f"{NOREC} (reasoning only: the grid spans the simulated humans' β = 3 and noisier people)",
             NO_RECIPE, SET, "inference.md#action-likelihood"),
    Constant("siftom.inference.model.ModelConfig.epsilon",
             "share of a uniform choice mixed into the Boltzmann policy, so one odd action never zeroes a goal",
             f"{NOREC} (reasoning only)", NO_RECIPE, SET, "planning.md#boltzmann-policy-siftomplanningpolicy"),
    Constant("siftom.inference.model.ModelConfig.unknown_prior",
             "prior mass of the \"unknown goal\" hypothesis (requests outside the goal library)",
             f"{NOREC} (reasoning only; a test shows the case it exists for)", NO_RECIPE, SET,
             "inference.md#hypotheses"),
    Constant("siftom.inference.model.ModelConfig.off_plan",
             "prior probability that a request is for an object outside the person's plan (any object left "
             "to bring, uniform): what lets a clear request for something no likely goal needs win",
             "three examples: the coffee and the bowl in kitchen-cereal-v0 are fetched; a clear "
             "recording of 'potato' in the salad is asked about, not fetched (0.02 fetched the potato)",
             NO_RECIPE, TUNED, "understanding.md#the-model"),
    Constant("siftom.inference.model.ModelConfig.help_kappa",
             "P(π_r | g) ∝ exp(help_kappa · steps the part saves the human)",
             f"{NOREC} (reasoning only: 10 more steps saved ≈ 2.7× as likely)", NO_RECIPE, SET,
             "inference.md#priors"),
    Constant("siftom.inference.model.ModelConfig.speech_weight",
             "multiplies the instruction log-likelihood (a likelihood temperature 1/T)",
             "seed-1 household development set, mean NLL of the gold command (optimum at 1.0)",
             NO_RECIPE, TUNED, "decisions.md"),
    # the phonetic likelihood (docs/likelihoods.md)
    Constant("siftom.likelihood.phonetic.PhoneticLikelihood(lam)",
             "nats per unit of phoneme edit cost: how much the transcript is trusted",
             NOREC, NO_RECIPE, TUNED, "likelihoods.md"),
    Constant("siftom.likelihood.phonetic.PhoneticLikelihood(asr_temperature)",
             "T_asr: divides the N-best log scores before the softmax that weighs the hypotheses",
             NOREC, NO_RECIPE, TUNED, "likelihoods.md"),
    Constant("siftom.likelihood.phonetic.PhoneticLikelihood(filler_cost)",
             "c_bg: cost per phoneme of a filler word or a word that sounds like no command word",
             NOREC, NO_RECIPE, TUNED, "likelihoods.md"),
    Constant("siftom.likelihood.phonetic.PhoneticLikelihood(filler_sub_penalty)",
             "π: extra cost of aligning a content phoneme onto a filler word's phoneme",
             NOREC, NO_RECIPE, TUNED, "likelihoods.md"),
    Constant("siftom.likelihood.phonetic.PhoneticLikelihood(content_insert_scale)",
             "scales the insertion cost of an unexplained object word (it may be a recognition error)",
             "the seed-0 free-v0 and grammar sets (the evaluation sets), then checked on the held-out "
             "carriers and seed 7",
             f"`benchmarks/rescore.py '{{\"content_insert_scale\": X}}' DATASET RESULTS` {RESEARCH}",
             TUNED, "benchmark.md#free-phrasings-requests-outside-siftoms-grammar"),
    Constant("siftom.likelihood.phonetic.PhoneticLikelihood(lost_word_weight)",
             "α: scores −λ (D(h, u) − α D(∅, u)), against \"the object word was lost\"",
             "39 kitchen `fetch` commands × 5 sampled phrasings (clean text) and the hypothesis "
             "\"can you pass me the the\"",
             f"{NOREC} (the script of the table in docs/likelihoods.md is not kept)", TUNED,
             "likelihoods.md#lost-words-lost_word_weight-03"),
    Constant("siftom.likelihood.background.R_NEAR",
             "relative phoneme cost r below which a heard word counts fully as a meaning word (g = 1)",
             NOREC, NO_RECIPE, SET, "likelihoods.md"),
    Constant("siftom.likelihood.background.R_FAR",
             "r above which a heard word is background (g = 0); linear ramp in between",
             NOREC, NO_RECIPE, SET, "likelihoods.md"),
    Constant("siftom.likelihood.background.EDGE_WEIGHT",
             "β: a meaning word's phonemes outside the heard span cost β × their deletion cost (a fragment is weaker evidence)",
             NOREC, NO_RECIPE, SET, "likelihoods.md"),
    Constant("siftom.likelihood.llm.LLMLikelihood(nbest_limit)",
             "hypotheses of the N-best scored by the LLM likelihood",
             f"{NOREC} (docs/benchmark.md calls it the paper's LLM likelihood, first 3 hypotheses)",
             NO_RECIPE, SET, "likelihoods.md#llm-scorer-llmpy-siftombackends"),
    Constant("siftom.likelihood.llm.LLMLikelihood(temperature)",
             "τ on the LLM's log-probabilities",
             "round 0 of the seed-0 sets, from the score cache (no τ helped both domains, so 1 stays)",
             f"`benchmarks/llm_rescore.py DATASET RUN` {RESEARCH}", TUNED,
             "benchmark.md#the-prompt-words-only-plain-or-with-pronunciations-sounds-the-default"),
    # the acoustic likelihood (docs/likelihoods.md)
    Constant("siftom.likelihood.acoustic.DEFAULT_TEMPERATURE",
             "T: the key-phrase alignment score is divided by T (nats) before it enters the likelihood",
             "seed-1 kitchen set, features of 163 stimuli, NLL of the gold command (flat for T = 40–100)",
             "`python recipes/calibrate.py --dataset DIR`", TUNED, "likelihoods.md"),
    Constant("siftom.likelihood.acoustic.DEFAULT_GAP_SCALE",
             "κ: T grows by exp(κ · gap) when the best alignment fits worse than a free phone loop",
             "seed-1 kitchen set (with T, above)", "`python recipes/calibrate.py --dataset DIR`", TUNED,
             "likelihoods.md"),
    Constant("siftom.likelihood.acoustic.DEFAULT_WHISPER_TEMPERATURE",
             "T_w: Whisper's teacher-forced score of each command's words is divided by T_w (tiny.en)",
             "seed-1 kitchen set (`datasets/dev1-kitchen`, 520 clips; seed 0 not looked at)",
             "`python recipes/calibrate.py --dataset DIR`", TUNED, "likelihoods.md"),
    Constant("siftom.likelihood.acoustic.DEFAULT_WHISPER_PAD_S",
             "Whisper's features are padded with its silence value to at least this many seconds",
             "seed-1 kitchen set (unpadded vs 3 s at T_w = 3)",
             f"`benchmarks/whisper_features.py DATASET OUT.jsonl --pads 0.01,3` {RESEARCH}", TUNED,
             "likelihoods.md"),
    Constant("siftom.likelihood.acoustic.DEFAULT_WHISPER_PRIOR",
             "β: how much of Whisper's own text prior (the texts scored on silence) is subtracted",
             "a seed-11 kitchen dev set in a 0.6 s room (λ = 0–1), checked on seed-57 kitchen and household "
             "sets with accented voices: no λ > 0 helped, so 0",
             "`python recipes/whisper_debias.py --dataset DIR --lambdas 0,0.1,0.25,0.5,0.75,1`", TUNED,
             "likelihoods.md"),
    Constant("siftom.likelihood.acoustic.DEFAULT_WHISPER_CANDIDATES",
             "K: Whisper scores the kept commands of at most K objects (those it heard, then the best by "
             "N-best × context)",
             "a seed-5 kitchen set built for it (225 clips, flite and espeak voices, babble at 10 and 5 dB): "
             "MAP unchanged from scoring every kept command for K = 4 and 5, texts per clip 12.96 → 8.21",
             "`python recipes/whisper_share.py --dataset DIR --ks 2,3,4,5,all`", TUNED, "likelihoods.md"),
    Constant("siftom.likelihood.acoustic.AcousticLikelihood(prune_mass)",
             "the commands scored acoustically: the smallest set holding this share of phonetic × context",
             "seed-1 kitchen set (checked: the gold command kept for 96.5 % of 509 clips; the value itself "
             f"{NOREC})", NO_RECIPE, TUNED, "likelihoods.md"),
    Constant("siftom.likelihood.acoustic.AcousticLikelihood(max_candidates)",
             "at most this many commands in that set", "as `prune_mass`", NO_RECIPE, TUNED, "likelihoods.md"),
    Constant("siftom.likelihood.acoustic.AcousticLikelihood(top_nbest)",
             "plus the best N-best matches, this many", "as `prune_mass`", NO_RECIPE, TUNED, "likelihoods.md"),
    # the utterance model (docs/understanding.md)
    Constant("siftom.language.understand.OPEN_CELLS",
             "(P(cell | request), P(cell | nobody asked)) of typed text and open-vocabulary transcripts, per "
             "cell: a request frame or none × what the target slots do (name an object, name nothing, lost, "
             "only negated, only context, none)",
             "stated, not fitted (docs/understanding.md gives the reasoning)", "`siftom bench understanding`", SET,
             "understanding.md#channels"),
    Constant("siftom.language.understand.SCENE_CELLS",
             "the same for a recogniser that writes only the scene's phrasings",
             "counted on the dev set's recordings (clean and 10 dB; 239 requests, 60 that asked nothing)",
             "`siftom bench understanding --set dev --conditions clean,10dB`", TUNED, "understanding.md#channels"),
    Constant("siftom.inference.understood.TRANSCRIPT_SLOPE",
             "how fast an open-vocabulary transcript's weight grows with its mean token log-probability",
             "log loss on the dev set's recordings, jointly with the next two; checked on the held-out set",
             "`siftom bench understanding --set dev --conditions clean,10dB`", TUNED, "understanding.md#channels"),
    Constant("siftom.inference.understood.TRANSCRIPT_MIDPOINT",
             "the mean token log-probability at which the transcript's reading weighs one half",
             "as `TRANSCRIPT_SLOPE`", "`siftom bench understanding --set dev --conditions clean,10dB`", TUNED,
             "understanding.md#channels"),
    Constant("siftom.inference.understood.SCENE_RELIABILITY",
             "the weight of the scene recogniser's reading of whether anybody asked",
             "as `TRANSCRIPT_SLOPE`", "`siftom bench understanding --set dev --conditions clean,10dB`", TUNED,
             "understanding.md#channels"),
    Constant("siftom.language.understand.SLOT_SLACK",
             "phoneme edit distance a target slot may be from a command's name at no cost",
             "the paper's Figure 1 ('potato' for 'tomato', d = 0.33) stays the tomato's at P > 0.75",
             "`siftom bench understanding`", TUNED, "understanding.md#the-model"),
    Constant("siftom.language.understand.SLOT_SHARPNESS",
             "nats a command loses per unit of phoneme edit distance past the slack",
             "dev set of `siftom bench understanding` (20 and 50 measured 1 point lower)",
             "`siftom bench understanding --set dev`", TUNED, "understanding.md#the-model"),
    Constant("siftom.language.understand.SLOT_CAP",
             "the most a target slot's words cost a command (nats)", "as `SLOT_SHARPNESS`",
             "`siftom bench understanding --set dev`", TUNED, "understanding.md#the-model"),
    Constant("siftom.language.understand.SCENE_WORDS_WEIGHT",
             "the share of the slot channel's sharpness and cap for an N-best from a scene-biased recogniser",
             "a seed-57 check (108 kitchen and 108 household stimuli, unseen voices and noises): at 1 the "
             "evaluator's siftom row lost 5.6 points in the kitchen; at 0.25 it is unchanged (kitchen) and "
             "+0.9 (household)", NO_RECIPE, TUNED, "understanding.md#the-model"),
    Constant("siftom.language.parse.MAX_WORDS",
             "the longest utterance read, in words (the rest is background)", "set: requests are far shorter",
             NO_RECIPE, SET, "understanding.md#the-model"),
    # is it an instruction at all (docs/speech.md)
    Constant("siftom.likelihood.nearness.CHANCE_R",
             "chance level of r per word length in phonemes: a heard word must be nearer to count",
             "measured: the 1st percentile of r for 4,000 random CMUdict words (seed 0) against the "
             "commands of every built-in scene; 400 other words (seed 7) checked",
             "`python studies/nearness.py 4000 0`", MEASURED,
             "speech.md#words-that-are-no-instruction-siftomlikelihoodnearness"),
    Constant("siftom.likelihood.nearness.CHANCE_QUANTILE",
             "the percentile of random words that defines chance (`CHANCE_R`)", NOREC,
             "`python studies/nearness.py 4000 0`", SET,
             "speech.md#words-that-are-no-instruction-siftomlikelihoodnearness"),
    Constant("siftom.likelihood.nearness.MIN_WEIGHT",
             "hypotheses with at least this share of the N-best weight are checked for a command word",
             NOREC, NO_RECIPE, SET, "speech.md#words-that-are-no-instruction-siftomlikelihoodnearness"),
    Constant("siftom.likelihood.nearness.ASR_TEMPERATURE",
             "the N-best softmax temperature of that check (the phonetic likelihood's T_asr)",
             f"{NOREC} (copied from `asr_temperature`)", NO_RECIPE, SET,
             "speech.md#words-that-are-no-instruction-siftomlikelihoodnearness"),
    Constant("siftom.likelihood.nearness.PAIR_EDGE",
             "β for two adjacent heard words run together (\"see real\" → cereal): the pair must cover a whole command word", NOREC, NO_RECIPE, SET,
             "speech.md#words-that-are-no-instruction-siftomlikelihoodnearness"),
    # decisions (docs/decisions.md)
    Constant("siftom.assist.decide.DEFAULT_CONFIDENT",
             "the teammate rule carries out a request when its most probable command holds this share; "
             "below it, it asks (or acts when ask-or-act finds no question worth its time)",
             f"{NOREC}: set by reasoning (three in four right before acting without a question)", NO_RECIPE, SET,
             "decisions.md"),
    Constant("siftom.assist.decide.DEFAULT_LOSS_AVERSION",
             "λ: a step lost weighs 1 + λ steps saved in the deciding rules",
             f"{S1}: the smallest λ with ≤ 3 % negative speedup on both domains",
             "`python recipes/loss_aversion.py RESULTS...`", TUNED, "decisions.md"),
    Constant("siftom.assist.decide.DEFAULT_ASK_COST",
             "the time of one spoken exchange in steps when a caller fixes it (and for pair questions)",
             NOREC, NO_RECIPE, SET, "decisions.md"),
    Constant("siftom.assist.decide.DEFAULT_QUESTION_PENALTY",
             "an interruption cost in steps on top of a question's time", "none by default (reasoning)",
             NO_RECIPE, SET, "decisions.md"),
    Constant("siftom.assist.decide.DEFAULT_UTILITY",
             "what the deciding rules measure a gain in: steps saved or speedup", NOREC, NO_RECIPE, SET,
             "decisions.md"),
    Constant("siftom.assist.decide.QUESTION_POOL",
             "pair questions are drawn from this many most probable commands", NOREC, NO_RECIPE, SET,
             "decisions.md"),
    Constant("siftom.assist.askcost.DEFAULT_SPEAKING_RATE_WPM",
             "speaking rate that prices a question's words", "literature (conversational English, 120–180 wpm)",
             NO_RECIPE, SET, "decisions.md"),
    Constant("siftom.assist.askcost.DEFAULT_TURN_GAP_S",
             "silence before each turn of the exchange", "literature (~0.2 s between turns)", NO_RECIPE, SET,
             "decisions.md"),
    Constant("siftom.assist.askcost.DEFAULT_ROBOT_LATENCY_S",
             "the robot's time to recognise the answer and start moving", NOREC, NO_RECIPE, SET, "decisions.md"),
    Constant("siftom.assist.askcost.DEFAULT_STEP_SECONDS",
             "seconds per world step (a metre walked, or one grab / put / open)", "reasoning (~1 m/s indoors)",
             NO_RECIPE, SET, "decisions.md"),
    # recognition (docs/speech.md)
    Constant("siftom.speech.asr.DEFAULT_NBEST",
             "hypotheses asked of the recogniser by the library, the service and the evaluator",
             f"{S1}: 10 vs 5 makes no average difference; 10 chosen so every door agrees",
             "`siftom eval --nbest 10|5 --models siftom,siftom-acoustic`", SET, "speech.md"),
    Constant("siftom.speech.audio.NOISE_FLOOR_DB",
             "every pocketsphinx decode gets seeded noise this many dB under the clip's RMS level",
             f"{S1}: 1-best WER on the clean stimuli for floors 50/40/30 dB",
             f"`benchmarks/noise_floor_sweep.py DATASET clean` {RESEARCH}", TUNED,
             "speech.md#noise-floor"),
    Constant("siftom.speech.asr.pocketsphinx.OPEN_BACKGROUND_WORDS",
             "`pocketsphinx-open`: the most frequent English words mixed into the phrasings' LM", NOREC,
             NO_RECIPE, SET, "speech.md"),
    Constant("siftom.speech.asr.pocketsphinx.OPEN_BACKGROUND_WEIGHT",
             "`pocketsphinx-open`: unigram mass of those words", NOREC, NO_RECIPE, SET, "speech.md"),
    # voice-activity detection (docs/speech.md, docs/streaming.md)
    Constant("siftom.speech.vad.detect_speech(threshold)",
             "Silero probability at which speech starts (ends below threshold − 0.15)",
             "Silero's own segmentation default", "`python studies/vad.py` (checks it)", SILERO,
             "speech.md#voice-activity-detection-siftomspeechvad"),
    Constant("siftom.speech.vad.detect_speech(min_speech_s)",
             "seconds of speech-probable chunks before a region starts", NOREC,
             "`python studies/vad.py` (checks it)", SET, "speech.md#voice-activity-detection-siftomspeechvad"),
    Constant("siftom.speech.vad.detect_speech(min_silence_s)",
             "seconds below the end threshold that end a region", NOREC, "`python studies/vad.py` (checks it)",
             SET, "speech.md#voice-activity-detection-siftomspeechvad"),
    Constant("siftom.speech.vad.detect_speech(pad_s)",
             "seconds added around each region", NOREC, "`python studies/vad.py` (checks it)", SET,
             "speech.md#voice-activity-detection-siftomspeechvad"),
    Constant("siftom.speech.segment.SegmentOptions.threshold",
             "streaming: Silero probability that starts an utterance", "Silero's own segmentation default",
             "`siftom bench stream` (checks it)", SILERO, "streaming.md"),
    Constant("siftom.speech.segment.SegmentOptions.neg_threshold",
             "streaming: probability below which silence is counted", "Silero's own segmentation default",
             "`siftom bench stream` (checks it)", SILERO, "streaming.md"),
    Constant("siftom.speech.segment.SegmentOptions.min_speech_s",
             "streaming: speech needed to start an utterance", NOREC, "`siftom bench stream` (checks it)", SET,
             "streaming.md"),
    Constant("siftom.speech.segment.SegmentOptions.min_silence_s",
             "streaming: silence that ends an utterance", NOREC, "`siftom bench stream` (checks it)", SET,
             "streaming.md"),
    Constant("siftom.speech.segment.SegmentOptions.pre_roll_s",
             "streaming: audio kept before the first speech frame", NOREC, "`siftom bench stream` (checks it)",
             SET, "streaming.md"),
    Constant("siftom.speech.segment.SegmentOptions.post_roll_s",
             "streaming: audio kept after the last speech frame (and when recognition starts early)", NOREC,
             "`siftom bench stream` (checks it)", SET, "streaming.md"),
    Constant("siftom.speech.vad._detect_spectral(min_excess_db)",
             "the older spectral rule (`method=\"spectral\"`): level over the 10th-percentile spectrum", NOREC,
             "`python studies/vad.py`", SET, "speech.md#voice-activity-detection-siftomspeechvad"),
    Constant("siftom.speech.vad._detect_spectral(min_voicing)",
             "the spectral rule: voicing peak at a pitch of 70–350 Hz", NOREC, "`python studies/vad.py`",
             SET, "speech.md#voice-activity-detection-siftomspeechvad"),
    Constant("siftom.speech.vad.LOUD_EXCESS_DB",
             "the spectral rule: a frame this loud needs only `LOUD_VOICING`", NOREC,
             "`python studies/vad.py`", SET, "speech.md#voice-activity-detection-siftomspeechvad"),
    Constant("siftom.speech.vad.LOUD_VOICING",
             "the spectral rule: voicing enough for a loud frame", NOREC, "`python studies/vad.py`", SET,
             "speech.md#voice-activity-detection-siftomspeechvad"),
    Constant("siftom.speech.vad.OVERSUBTRACT",
             "the background spectrum is subtracted this many times over (the SNR estimate too)",
             f"{NOREC} (reasoning: its fluctuations stay below)", "`python studies/vad.py`", SET,
             "speech.md#voice-activity-detection-siftomspeechvad"),
    # Whisper's own thresholds
    Constant("siftom.speech.asr.whisper.NO_SPEECH_PROB",
             "`whisper` engine: no speech when Whisper's no-speech probability is above this …",
             "faster-whisper's `no_speech_threshold`", "—", WHISPER, "speech.md"),
    Constant("siftom.speech.asr.whisper.NO_SPEECH_LOGPROB",
             "… and the best hypothesis' mean log-probability below this",
             "faster-whisper's `log_prob_threshold`", "—", WHISPER, "speech.md"),
    Constant("siftom.speech.asr.openai_server.NO_SPEECH_PROB",
             "OpenAI-compatible server: the same no-speech rule per segment", "Whisper's `no_speech_threshold`",
             "—", WHISPER, "speech.md"),
    Constant("siftom.speech.asr.openai_server.NO_SPEECH_LOGPROB",
             "OpenAI-compatible server: the same rule's log-probability", "Whisper's `logprob_threshold`", "—",
             WHISPER, "speech.md"),
    Constant("siftom.speech.whisper_score.LOGPROB_THRESHOLD",
             "below this mean token log-probability Whisper's own transcript (a second carrier) is dropped",
             "openai-whisper's and faster-whisper's `logprob_threshold`", "—", WHISPER, "likelihoods.md"),
    # the evaluation sets (as in the paper)
    Constant("siftom.people.stimuli.DEFAULT_SNRS",
             "`siftom dataset build`: the noisy conditions besides clean, in dB", "the paper's conditions", "—",
             PAPER, "benchmark.md#what-is-in-the-default-dataset"),
    Constant("siftom.people.stimuli.DEFAULT_SCENARIOS",
             "`siftom dataset build`: scenarios per set", "the paper's 26 scenarios", "—", PAPER,
             "benchmark.md#what-is-in-the-default-dataset"),
    Constant("siftom.people.stimuli.DEFAULT_SPEAKERS",
             "`siftom dataset build`: speakers per scenario", "the paper's five participants", "—", PAPER,
             "benchmark.md#what-is-in-the-default-dataset"),
)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def constants_table(entries: Sequence[Constant] = CONSTANTS, doc_prefix: str = "../") -> str:
    """The Markdown table of ``entries``, every value read from the code."""
    lines = ["| constant | value | what it does | chosen on | refit with | origin |",
             "|---|---|---|---|---|---|"]
    for c in entries:
        if c.origin not in ORIGINS:
            raise SiftomError(f"{c.ref}: origin must be one of {', '.join(ORIGINS)}, got {c.origin!r}")
        value = f"`{_cell(fmt(value_of(c.ref)))}`"
        chosen = _cell(c.chosen_on)
        if c.doc:
            chosen += f" ([{c.doc.split('#')[0].removesuffix('.md')}]({doc_prefix}{c.doc}))"
        lines.append(f"| `{c.ref}` | {value} | {_cell(c.does)} | {chosen} | {_cell(c.refit)} | {c.origin} |")
    return "\n".join(lines)


def not_recorded(entries: Sequence[Constant] = CONSTANTS) -> list[str]:
    """The entries whose data set is not recorded anywhere in the repository."""
    return [c.ref for c in entries if c.chosen_on.startswith(NOT_RECORDED)]
