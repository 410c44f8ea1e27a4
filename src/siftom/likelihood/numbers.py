"""Counts as words: the spoken form of a number (the bottom of the likelihood package)."""

from __future__ import annotations

NUMBER_WORDS = ["zero", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine", "ten", "eleven",
                "twelve", "thirteen", "fourteen", "fifteen", "sixteen", "seventeen", "eighteen", "nineteen", "twenty"]
_TENS = ["twenty", "thirty", "forty", "fifty", "sixty", "seventy", "eighty", "ninety"]


def number_word(n: int) -> str:
    """Spoken form of a small count ("three"); larger counts are written as digits' words."""
    if 0 <= n < len(NUMBER_WORDS):
        return NUMBER_WORDS[n]
    if n < 100:
        t, u = divmod(n, 10)
        return _TENS[t - 2] + ("" if u == 0 else " " + NUMBER_WORDS[u])
    return " ".join(NUMBER_WORDS[int(d)] for d in str(n))
