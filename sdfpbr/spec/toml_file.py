"""The one TOML reader: every spec file, docs entry and Sphinx directive file goes through
``read_toml``, so a missing, unreadable, special, oversized, deeply nested or malformed file
gives the same one-line error (sdfpbr.inputs reads the bytes)."""
from __future__ import annotations

from pathlib import Path

from ..errors import SpecError
from ..inputs import MAX_NESTING, check_nesting, read_input_text


def read_toml(path: str | Path, what: str = "spec file") -> dict:
    import tomllib   # here, not at the top: a chart without a spec file does not pay its import
    p = Path(path)
    text = read_input_text(p, what, "spec")
    try:
        return check_nesting(tomllib.loads(text), str(p))
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{p}: malformed TOML: {exc}") from None
    except RecursionError:
        raise SpecError(f"{p}: values nested more than {MAX_NESTING} deep") from None


def parse_toml_text(text: str, where: str) -> dict:
    """Inline TOML (a Sphinx directive's body) with the same error mapping."""
    import tomllib
    try:
        return check_nesting(tomllib.loads(text), where)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{where}: malformed inline TOML: {exc}") from None
    except RecursionError:
        raise SpecError(f"{where}: values nested more than {MAX_NESTING} deep") from None
