"""Value checks and text parsers shared by every spec field: one message per mistake, the same
whether the value came from Python, TOML or a command-line flag."""
from __future__ import annotations

import math
import numbers
import sys
import unicodedata

import numpy as np

from ..errors import SpecError, did_you_mean


def quote(v, limit: int = 60) -> str:
    """repr(v), cut short: a message stays one readable line whatever was passed."""
    text = repr(v)
    return text if len(text) <= limit else text[:limit - 1] + "…"


def is_number(v) -> bool:
    """Python and numpy ints and floats; not booleans (True is an int to Python, not to users)."""
    if type(v) is float or type(v) is int:   # most values, without the ABC checks (a spec checks ~250)
        return True
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


def number(v, what: str, lo: float = -math.inf, hi: float = math.inf, integer: bool = False):
    if not is_number(v):
        raise SpecError(f"{what} must be a number, got {quote(v)}")
    if type(v) is int or (type(v) is not float and isinstance(v, numbers.Integral)):
        v, finite = int(v), True      # (math.isfinite overflows on ints beyond float range)
    else:
        v = float(v)
        finite = math.isfinite(v)
    if integer and finite and int(v) != v:   # int(inf) and int(nan) raise
        raise SpecError(f"{what} must be a whole number, got {quote(v)}")
    if not finite:
        raise SpecError(f"{what} must be a finite number, got {quote(v)}")
    if not lo <= v <= hi:
        raise SpecError(f"{what} must be in [{lo:g}, {hi:g}], got {quote(v)}")
    return int(v) if integer else float(v)


def boolean(v, what: str) -> bool:
    if not isinstance(v, (bool, np.bool_)):
        raise SpecError(f"{what} must be true or false, got {quote(v)}")
    return bool(v)


# Unicode's Bidi_Control characters: drawn, they reorder the text around them (Pillow with
# libraqm applies the bidi algorithm: a title "\u202eevil" was drawn as "live").
BIDI_CONTROLS = frozenset("\u061c\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")


def describe_char(ch: str) -> str:
    """'U+1F642 SLIGHTLY SMILING FACE (🙂)': a character named so that a message can show it."""
    o = ord(ch)
    if 0xDC80 <= o <= 0xDCFF:   # how Python keeps a byte of a command line that is not UTF-8
        return f"U+{o:04X} (not a character: the byte 0x{o - 0xDC00:02X}, not UTF-8)"
    category = unicodedata.category(ch)
    name = unicodedata.name(ch, "") or {"Cc": "(a control character)", "Co": "(a private-use character)",
                                        "Cn": "(unassigned)"}.get(category, "(unnamed)")
    shown = f" ({ch})" if ch.isprintable() and category[0] != "M" else ""
    return f"U+{o:04X} {name}{shown}"


def text(v, what: str, longest: int | None = None) -> str:
    """Text as written: no bidirectional controls and no control characters but a tab or a line
    break (they would reorder, hide or garble what is drawn or printed of it); at most
    ``longest`` characters where given."""
    if not isinstance(v, str):
        raise SpecError(f"{what} must be text, got {quote(v)}")
    if longest is not None and len(v) > longest:
        raise SpecError(f"{what} is {len(v)} characters long; at most {longest}: {quote(v)}")
    if not v.isprintable():   # the few texts with anything but printable characters and spaces
        bad = [c for c in dict.fromkeys(v)
               if c in BIDI_CONTROLS or (unicodedata.category(c) == "Cc" and c not in "\t\n\r")]
        if bad:
            bidi = sum(c in BIDI_CONTROLS for c in bad)
            kind = ("bidirectional control" if bidi == len(bad) else "control" if not bidi
                    else "bidirectional control or control")
            more = f" and {len(bad) - 6} more" if len(bad) > 6 else ""
            raise SpecError(f"{what} must not contain {kind} characters, which reorder or hide what is shown: "
                            f"{', '.join(describe_char(c) for c in bad[:6])}{more}; got {quote(v)}")
    return v


def choice(v, what: str, choices) -> str:
    if not isinstance(v, str) or v not in choices:
        raise SpecError(f"{what} {quote(v)} is not allowed{did_you_mean(v, choices)}; allowed: {', '.join(choices)}")
    return v


def sequence(v, what: str, n: int | None = None, form: str = "a list") -> tuple:
    """A list or tuple (of length ``n``), not text: a string is a sequence to Python only."""
    if isinstance(v, np.ndarray) and v.ndim == 1:
        v = v.tolist()
    if not isinstance(v, (list, tuple)) or (n is not None and len(v) != n):
        raise SpecError(f"{what} must be {form}, got {quote(v)}")
    return tuple(v)


def vec3(v, what: str, lo: float = -math.inf, hi: float = math.inf) -> tuple[float, float, float]:
    comps = sequence(v, what, 3, "three numbers")
    return tuple(number(c, f"{what} components", lo, hi) for c in comps)


def unit(v, what: str) -> tuple[float, float, float]:
    v = vec3(v, what)
    n = math.hypot(*v)   # no overflow to inf (which made (1e200, 0, 0) a zero vector)
    if not n > 0:
        raise SpecError(f"{what} must be a non-zero vector, got {v}")
    if abs(n - 1.0) <= 4 * sys.float_info.epsilon:
        return v         # already unit: keep it, so a spec written out and read back is equal
    return tuple(c / n for c in v)


# ---- text forms (flags, sweep values, and the string spellings TOML and Python also accept) ----

def split_text(text: str, sep: str, n: int, what: str, form: str) -> list[str]:
    parts = [p.strip() for p in str(text).split(sep)]
    if len(parts) != n or not all(parts):
        raise SpecError(f"{what} must be {form}, got {quote(text)}")
    return parts


def number_text(text: str, what: str):
    """'3' -> 3, '2.5' -> 2.5 (then refused by an integer check, with the same message as 2.5)."""
    s = str(text).strip()
    for convert in (int, float):
        try:
            return convert(s)
        except ValueError:
            pass
    # the message a non-number gets from TOML or Python too (an integer field then says "whole")
    raise SpecError(f"{what} must be a number, got {quote(text)}")


def bool_text(text: str, what: str) -> bool:
    word = str(text).strip().lower()
    if word in ("true", "on", "yes", "1"):
        return True
    if word in ("false", "off", "no", "0"):
        return False
    raise SpecError(f"{what} must be true or false, got {quote(text)}")


def parse_range(text: str, what: str = "range") -> tuple[float, float]:
    return tuple(number_text(p, what) for p in split_text(text, ":", 2, what, "LO:HI, e.g. 0:1"))


def parse_size(text, what: str = "size") -> tuple[int, int]:
    """'WxH' or a [W, H] pair; each side is checked as width and height are."""
    if isinstance(text, str):
        w, h = (number_text(p, side)
                for p, side in zip(split_text(text.lower(), "x", 2, what, "WxH, e.g. 1024x1024"), ("width", "height")))
    else:
        w, h = sequence(text, what, 2, "WxH or a [width, height] pair")
    return w, h


def parse_color(text: str, what: str = "base color", space: str = "linear") -> tuple[float, float, float]:
    return tuple(number_text(p, what) for p in split_text(text, ",", 3, what, f"R,G,B ({space}, 0..1)"))


def parse_names(text: str, seps: str = ",") -> tuple[str, ...]:
    """'gold,copper' (or 'gold+copper' in a sweep's list of values) -> ('gold', 'copper');
    '' -> () (an empty list); an empty item stays, for the check to refuse."""
    s = str(text)
    for sep in seps[1:]:
        s = s.replace(sep, seps[0])
    return tuple(p.strip() for p in s.split(seps[0])) if s.strip() else ()
