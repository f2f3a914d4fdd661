"""A small S-expression reader/writer for KiCad files (enough for symbols and schematics)."""
from __future__ import annotations

import re

_TOKEN = re.compile(r'\s*(?:(\()|(\))|"((?:[^"\\]|\\.)*)"|([^\s()"]+))', re.S)


class Q(str):
    """A quoted string atom."""


def parse(text: str):
    stack: list[list] = [[]]
    pos = 0
    n = len(text)
    while pos < n:
        m = _TOKEN.match(text, pos)
        if not m:
            if text[pos:].strip() == "":
                break
            raise ValueError(f"bad s-expression at {pos}: {text[pos:pos + 40]!r}")
        pos = m.end()
        if m.group(1):
            stack.append([])
        elif m.group(2):
            done = stack.pop()
            stack[-1].append(done)
        elif m.group(3) is not None:
            stack[-1].append(Q(m.group(3).replace('\\"', '"').replace("\\\\", "\\")))
        else:
            stack[-1].append(m.group(4))
    if len(stack) != 1:
        raise ValueError("unbalanced s-expression")
    return stack[0][0] if len(stack[0]) == 1 else stack[0]


def _atom(a) -> str:
    if isinstance(a, Q):
        return '"' + a.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'
    if isinstance(a, bool):
        return "yes" if a else "no"
    if isinstance(a, float):
        s = f"{a:.6f}".rstrip("0").rstrip(".")
        return "0" if s in ("-0", "") else s
    return str(a)


def dump(e, indent: int = 0) -> str:
    """KiCad-like layout: a list whose items are all atoms goes on one line."""
    if not isinstance(e, list):
        return _atom(e)
    if all(not isinstance(x, list) for x in e) or (
        len(e) <= 4 and all(not isinstance(x, list) or
                            all(not isinstance(y, list) for y in x) for x in e)
        and sum(1 for x in e if isinstance(x, list)) <= 2):
        return "(" + " ".join(dump(x) for x in e) + ")"
    pad = "\t" * (indent + 1)
    head = []
    rest = []
    for x in e:
        if not rest and not isinstance(x, list):
            head.append(_atom(x))
        else:
            rest.append(x)
    out = "(" + " ".join(head)
    for x in rest:
        out += "\n" + pad + dump(x, indent + 1)
    return out + "\n" + "\t" * indent + ")"


def find(e: list, key: str):
    for x in e:
        if isinstance(x, list) and x and x[0] == key:
            return x
    return None


def find_all(e: list, key: str):
    return [x for x in e if isinstance(x, list) and x and x[0] == key]
