"""A seeded byte mutator for the input gates: what a careless user or an attacker sends.

Each mutation applies one to four operations to a valid seed: flip or drop
bytes, insert random bytes, insert or substitute a token known to break parsers
(control characters, NaN, huge numbers, YAML tags and aliases, brackets, very
long strings), duplicate or truncate. The same seed and the same input number
give the same bytes.
"""

from __future__ import annotations

import numpy as np

TOKENS = (
    b"nan", b"inf", b"-inf", b"-1", b"0", b"1e308", b"-1e308", b"1e-308", b"9" * 400, b"0x1f", b"1_000",
    b"!!python/object/apply:os.system ['true']", b"!!int abc", b"!!timestamp x", b"!!binary AAAA", b"&a", b"*a",
    b"<<: *a", b"[", b"]", b"{", b"}", b"[[[[[[[[[[", b"? [a, b]\n: 1", b"\x00", b"\x06", b"\x7f", b"\xff\xfe",
    b"\xc3\x28", b"~", b"null", b"true", b"''", b'"', b"\n", b": ", b"- ", b"x" * 300, b"\xc3\xa9", b"\r\n", b"#",
    b"%YAML 1.1\n", b"---\n", b"...\n", b"\t", b"=", b",", b";", b"../../", b"/dev/zero", b"-0", b"1e6", b"65536",
    b"4294967296", b"-9223372036854775809",
)
_DELIMS = b" \t\n,:=[]{}"


def _token_bounds(data: bytes, rng: np.random.Generator) -> tuple[int, int]:
    """A random run of bytes between delimiters (a scalar, a key, a number)."""
    if not data:
        return 0, 0
    i = int(rng.integers(0, len(data)))
    lo = i
    while lo > 0 and data[lo - 1] not in _DELIMS:
        lo -= 1
    hi = i
    while hi < len(data) and data[hi] not in _DELIMS:
        hi += 1
    return lo, hi


def mutate(seed: bytes, rng: np.random.Generator) -> bytes:
    """One mutant of ``seed``."""
    data = bytearray(seed)
    for _ in range(int(rng.integers(1, 5))):
        op = int(rng.integers(0, 8))
        n = len(data)
        pos = int(rng.integers(0, n + 1))
        if op == 0 and n:  # flip bits of one byte
            data[min(pos, n - 1)] ^= 1 << int(rng.integers(0, 8))
        elif op == 1 and n:  # delete a run
            del data[pos:pos + int(rng.integers(1, 16))]
        elif op == 2:  # insert random bytes
            data[pos:pos] = rng.integers(0, 256, int(rng.integers(1, 8)), dtype=np.uint8).tobytes()
        elif op == 3:  # insert a token
            data[pos:pos] = TOKENS[int(rng.integers(0, len(TOKENS)))]
        elif op in (4, 5):  # replace a scalar by a token
            lo, hi = _token_bounds(bytes(data), rng)
            data[lo:hi] = TOKENS[int(rng.integers(0, len(TOKENS)))]
        elif op == 6 and n:  # duplicate a slice
            end = min(n, pos + int(rng.integers(1, 64)))
            data[pos:pos] = data[max(0, pos - 1):end]
        elif n:  # truncate
            del data[pos:]
    return bytes(data)
