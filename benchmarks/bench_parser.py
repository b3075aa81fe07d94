"""Per-line cost of the block parser on normal, random and pathological lines (issue 26).

Run:  python benchmarks/bench_parser.py [--random 2000] [--seed 1] [--repeat 3]

The simulator parses every line a sender writes with ``BlockParser.parse_line``, and
``check``/``send``/``verify`` parse whole files, so the figures are per line, in the
same run, each the best of ``--repeat`` passes (``time.perf_counter``):

* normal lines: a program of moves, arcs, feeds and comments (the speed the simulator
  needs), and the word reader alone with the old backtracking patterns and the new ones
  on the same lines (it must stay as fast as the regex it replaced);
* random lines up to 10,000 characters (letters, digit runs up to 400 long, signs,
  points, comments, junk) in GRBL, LinuxCNC and generic dialects: mean and worst ms/line
  against the issue's bound of 5 ms;
* the pathological lines that hung the old tokenizer (5 words of 8 digits + ``!``,
  11 of 6 digits + ``!`` in GRBL, 9 of 20 digits + ``!`` in LinuxCNC) and 10,000-char
  lines, each timed alone.

Baselines in the same run: ``float()`` over the same lines' digit runs (the floor of any
reader that converts numbers), and the old backtracking pattern
``(?:[A-Z][+-]?(?:[0-9]+\\.?[0-9]*|\\.[0-9]+))*`` on growing "N words of 8 digits + !"
lines (stopped at 5 words, 5^8 splits: its time grows ~8x per word; 11 words of 6 digits
never finish), next to the new pattern on the same lines.
"""

from __future__ import annotations

import argparse
import re
import time

import numpy as np

from gcode import GENERIC, GRBL, LINUXCNC, BlockParser, GCodeError
from gcode.blockparser import _WORD_RE, _WORDS_RE

_OLD_WORDS_RE = re.compile(r"(?:[A-Z][+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+))*")
_DIGITS = re.compile(r"[0-9]+\.?[0-9]*")


def _normal_program(rng: np.random.Generator, n: int) -> list[str]:
    lines = ["G21 G90 G94", "G0 X0 Y0 Z5", "G1 Z-1 F300 (plunge)"]
    x = y = 0.0
    while len(lines) < n:
        k = rng.integers(0, 10)
        x2, y2 = x + float(rng.normal(0, 5)), y + float(rng.normal(0, 5))
        if k == 0:
            lines.append(f"G2 X{x2:.3f} Y{y2:.3f} I{(x2 - x) / 2:.3f} J{(y2 - y) / 2:.3f}")
        elif k == 1:
            z, f = rng.normal(-1, 0.1), rng.integers(200, 2000)
            lines.append(f"G1 X{x2:.3f} Y{y2:.3f} Z{z:.3f} F{f}")
        elif k == 2:
            lines.append(f"(pass {len(lines)})")
            continue
        else:
            lines.append(f"G1 X{x2:.3f} Y{y2:.3f} Z{rng.normal(-1, 0.1):.3f}")
        x, y = x2, y2
    return lines


def _random_line(rng: np.random.Generator) -> str:
    parts = []
    size = int(rng.integers(1, 10_000))
    total = 0
    while total < size:
        k = rng.integers(0, 6)
        if k == 0:
            s = "".join(rng.choice(list("0123456789"), int(rng.integers(1, 400))))
        elif k == 1:
            s = str(rng.choice(list("GXYZABCIJKRFNMSTPOE")))
        elif k == 2:
            s = str(rng.choice(list(".+- ()!;")))
        else:
            s = f"{rng.choice(list('XYZIJKF'))}{rng.normal(0, 100):.3f}"
        parts.append(s)
        total += len(s)
    return "".join(parts)[:size]


def _per_line_ms(lines: list[str], dialect, repeat: int) -> np.ndarray:
    best = np.full(len(lines), np.inf)
    for _ in range(repeat):
        bp = BlockParser(dialect)
        for i, line in enumerate(lines):
            t0 = time.perf_counter()
            try:
                bp.parse_line(line, i + 1)
            except GCodeError:
                pass
            best[i] = min(best[i], time.perf_counter() - t0)
    return best * 1e3


def _float_ms(lines: list[str], repeat: int) -> np.ndarray:
    runs = [_DIGITS.findall(line) for line in lines]
    best = np.full(len(lines), np.inf)
    for _ in range(repeat):
        for i, digits in enumerate(runs):
            t0 = time.perf_counter()
            for d in digits:
                float(d)
            best[i] = min(best[i], time.perf_counter() - t0)
    return best * 1e3


def _pattern_ms(pattern: re.Pattern[str], code: str, repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        pattern.fullmatch(code)
        best = min(best, time.perf_counter() - t0)
    return best * 1e3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--random", type=int, default=2000, help="random lines per dialect")
    ap.add_argument("--normal", type=int, default=20000, help="lines of the normal program")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)

    normal = _normal_program(rng, args.normal)
    ms = _per_line_ms(normal, GENERIC, args.repeat)
    fl = _float_ms(normal, args.repeat)
    print(f"normal program, {len(normal)} lines (moves, arcs, comments), generic dialect:")
    p99 = np.percentile(ms, 99) * 1e3
    print(f"  parse_line  mean {ms.mean() * 1e3:7.2f} us/line   p99 {p99:7.2f} us")
    print(f"  float() of the same numbers (baseline) mean {fl.mean() * 1e3:7.2f} us/line")
    codes = ["".join(ln.split("(")[0].split()) for ln in normal]
    old_word = re.compile(r"([A-Z])([+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+))")
    for name, whole, word in (
        ("old backtracking patterns", _OLD_WORDS_RE, old_word),
        ("new possessive patterns  ", _WORDS_RE, _WORD_RE),
    ):
        best = np.inf
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            for c in codes:
                if "E" not in c and whole.fullmatch(c) is not None:
                    [(m[0], float(m[1]), m[1]) for m in word.findall(c)]
            best = min(best, time.perf_counter() - t0)
        print(f"  word reader, {name} {best / len(codes) * 1e6:7.2f} us/line")

    print(f"\nrandom lines up to 10,000 characters ({args.random} per dialect):")
    for dialect in (GRBL, LINUXCNC, GENERIC):
        lines = [_random_line(rng) for _ in range(args.random)]
        ms = _per_line_ms(lines, dialect, args.repeat)
        fl = _float_ms(lines, args.repeat)
        worst = int(np.argmax(ms))
        print(
            f"  {dialect.name:9s} mean {ms.mean():6.3f} ms  max {ms.max():6.3f} ms "
            f"(a {len(lines[worst])}-char line)  lines over 5 ms: {int((ms > 5).sum())}  "
            f"| float() baseline mean {fl.mean():6.3f} ms max {fl.max():6.3f} ms"
        )

    print("\npathological lines (each alone, ms):")
    cases = [
        ("5 words of 8 digits + '!'", "".join(c + "12345678" for c in "XYZXY") + "!", GRBL),
        ("11 words of 6 digits + '!'", "".join(c + "123456" for c in "XYZIJKXYZIJ") + "!", GRBL),
        ("9 words of 20 digits + '!'", "".join(c + "1" * 20 for c in "XYZABCIJK") + "!", LINUXCNC),
        ("10,000 chars: words of 9 digits + '!'", ("X123456789" * 1000)[:9999] + "!", GENERIC),
        ("10,000 chars: 5000 '()' comments", "()" * 5000, GENERIC),
        ("10,000 chars: '(' x 10000 (grbl)", "(" * 10000, GRBL),
        ("10,000 chars: X + 9999 digits", "X" + "9" * 9999, GENERIC),
    ]
    for name, line, dialect in cases:
        ms = _per_line_ms([line], dialect, args.repeat)[0]
        fl = _float_ms([line], args.repeat)[0]
        print(f"  {name:40s} {dialect.name:9s} {ms:8.3f} ms   float() baseline {fl:7.3f} ms")

    print("\nold backtracking pattern vs the new one, 'N words of 8 digits + !' (ms):")
    for words in range(1, 6):
        code = "".join(c + "12345678" for c in "XYZXYZ"[:words]) + "!"
        old = _pattern_ms(_OLD_WORDS_RE, code, 1)
        new = _pattern_ms(_WORDS_RE, code, args.repeat)
        print(f"  {words} words: old {old:10.3f} ms   new {new:8.4f} ms")


if __name__ == "__main__":
    main()
