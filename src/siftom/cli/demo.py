"""``siftom demo``: the main job end to end on the embedded default (paper, Figure 2).

kitchen-cereal-v0: the human has taken milk and a bowl. "Can you pass me the cereal" is
spoken by a synthetic voice, mixed with pink noise at 5 dB (seed 1: the recogniser hears only
"i'm", the object word is lost), and goes through the path every door takes
(``siftom.listen``): SIFToM infers the command from the audio and what the human did, and the
decision rule says what the robot does; the words alone are shown too.
"""

from __future__ import annotations

import json
from pathlib import Path

import click
from rich.console import Console

from siftom.speech.cli_options import whisper_model_option


@click.command("demo")
@whisper_model_option
@click.option("--scenario", "scenario_id", default="kitchen-cereal-v0", show_default=True)
@click.option("--text", default="can you pass me the cereal", show_default=True, help="What the human says.")
@click.option("--voice", default="flite-slt", show_default=True, help="TTS voice (see `siftom voices`).")
@click.option("--noise", default="pink", show_default=True,
              help="Noise: babble, pink, white, brown, hum, or a WAV file/folder.")
@click.option("--snr", default=5.0, show_default=True, help="Signal-to-noise ratio in dB.")
@click.option("--seed", default=1, show_default=True)
@click.option("--likelihood", type=click.Choice(["acoustic", "phonetic"]), default="acoustic", show_default=True,
              help="acoustic: score the audio itself; phonetic: score the N-best transcripts.")
@click.option("--out", "out_dir", type=click.Path(path_type=Path), default=Path("siftom-demo"), show_default=True)
def demo_cmd(scenario_id: str, text: str, voice: str, noise: str, snr: float, seed: int, likelihood: str,
             out_dir: Path) -> None:
    """Speak, add noise, transcribe, infer: the whole SIFToM chain on one scenario."""
    from rich.markup import escape

    from siftom.api import listen
    from siftom.cli.inference import print_answer, whisper_missing
    from siftom.errors import BackendUnavailableError

    why = whisper_missing() if likelihood == "acoustic" else None
    if why:  # the story is Whisper's: without it the recogniser's "i'm" is all there is to hear
        raise BackendUnavailableError(
            f"siftom demo scores the recording with Whisper, which is not installed here: {why} "
            "(or run the demo on the recogniser's words alone: siftom demo --likelihood phonetic)")
    from siftom.scenarios.base import get_scenario
    from siftom.speech import get_noise, mix_at_snr, synthesize, write_wav
    from siftom.world.render import render_scenario

    con = Console()
    sc = get_scenario(scenario_id)
    con.rule(f"[bold]{sc.id}[/bold]")
    con.print(sc.description)
    con.print("the robot saw the human do:")
    for k, a in enumerate(sc.actions, 1):
        con.print(f"  {k:2d}. {sc.world.format_action(a)}")
    out_dir.mkdir(parents=True, exist_ok=True)
    clean = synthesize(text, voice)
    mixed = mix_at_snr(clean, get_noise(noise), snr, rng=seed)
    wav = write_wav(out_dir / "instruction.wav", mixed)
    con.print(f'\nthe human says "{text}" ({voice}), heard through {noise} noise at {snr:g} dB -> {wav}')
    # the one path every door takes (siftom.listen): detector, recogniser, likelihood, decision rule
    ans = listen(wav, sc.id, likelihood=likelihood)
    if ans.asr is not None:
        con.print(f'ASR 1-best: "[bold]{escape(ans.asr.text)}[/bold]"   (N-best: {len(ans.asr.nbest)}, '
                  f"real-time factor {ans.asr.rtf:.2f})")
        for h in ans.asr.nbest[:5]:
            con.print(f"    {h.score:8.2f}  {escape(h.text)}")
    post = ans.posterior
    con.rule(f"SIFToM (what the human did + {'the audio' if likelihood == 'acoustic' else 'the N-best words'})")
    print_answer(ans, con)
    literal = listen(wav, sc.id, mode="speech-only", likelihood="phonetic").posterior
    alone = listen(wav, sc.id, mode="speech-only", likelihood=likelihood).posterior
    con.print(f"from the transcripts alone: {literal.command} (P={literal.commands[0][1]:.2f}); "
              f"from the {likelihood} likelihood alone: {alone.command} (P={alone.commands[0][1]:.2f}); "
              f"the human meant {sc.command}")
    png = render_scenario(sc, out_dir / "demo.png", posterior=post, doing=ans.doing)
    (out_dir / "answer.json").write_text(json.dumps(ans.to_json(), indent=2))
    con.print(f"\npicture: {png}   answer: {out_dir / 'answer.json'}")
    con.print("next: [bold]siftom serve[/bold] and open http://127.0.0.1:8000 for the browser demo; "
              "`siftom --help` lists everything.")


def register(root: click.Group) -> None:
    root.add_command(demo_cmd)
