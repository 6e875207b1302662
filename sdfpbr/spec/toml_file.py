"""The one TOML reader: every spec file, docs entry and Sphinx directive file goes through
``read_toml``, so a missing, unreadable or malformed file gives the same one-line error."""
from __future__ import annotations

from pathlib import Path

from ..errors import SpecError


def read_toml(path: str | Path, what: str = "spec file") -> dict:
    import tomllib   # here, not at the top: a chart without a spec file does not pay its import
    p = Path(path)
    try:
        return tomllib.loads(p.read_text(encoding="utf-8-sig"))   # a BOM (Windows editors) is not TOML
    except FileNotFoundError:
        raise SpecError(f"{what} {p} does not exist") from None
    except IsADirectoryError:
        raise SpecError(f"{what} {p} is a directory") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError(f"cannot read {what} {p}: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{p}: malformed TOML: {exc}") from None
    except RecursionError:
        raise SpecError(f"{p}: values nested too deeply (a spec's arrays are at most 2 deep)") from None


def parse_toml_text(text: str, where: str) -> dict:
    """Inline TOML (a Sphinx directive's body) with the same error mapping."""
    import tomllib
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{where}: malformed inline TOML: {exc}") from None
    except RecursionError:
        raise SpecError(f"{where}: values nested too deeply (a spec's arrays are at most 2 deep)") from None
