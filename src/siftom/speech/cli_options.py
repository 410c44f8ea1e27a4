"""``--whisper-model NAME|DIR``: the ``whisper_model`` setting for one command.

A packaged model's name (``tiny.en``, ``base``) or a CTranslate2 whisper folder is checked, then set as ``$SIFTOM_WHISPER_MODEL`` for
this process and the workers it starts, so the teacher-forced scorer of the acoustic likelihood
and Whisper's transcript (and ``--engine whisper``) all use it.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

import click


def _apply(ctx: click.Context, param: click.Parameter, value: str | None) -> None:
    if value is None:
        return
    from siftom.errors import SiftomError
    from siftom.speech.asr.whisper import WHISPER_MODEL_ENV, whisper_model_dir

    try:
        os.environ[WHISPER_MODEL_ENV] = str(whisper_model_dir(value).resolve())
    except SiftomError as exc:  # a usage error: exit 2 with the fix
        raise click.BadParameter(str(exc), ctx=ctx, param=param) from None


def whisper_model_option(f: Callable[..., Any]) -> Callable[..., Any]:
    """Add ``--whisper-model DIR`` (not passed to the command: it sets the setting)."""
    return click.option(
        "--whisper-model", default=None, expose_value=False, callback=_apply, metavar="NAME|DIR",
        help="the Whisper model for the acoustic likelihood and Whisper's transcript: tiny.en, base "
             "(pip install 'siftom[whisper-base]') or a CTranslate2 whisper folder "
             "(default: $SIFTOM_WHISPER_MODEL, else the packaged tiny.en)")(f)
