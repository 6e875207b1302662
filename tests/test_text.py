"""Titles and labels in any script: characters the main font (DejaVu Sans) lacks are drawn from
fallback fonts (WenQuanYi Micro Hei for CJK, Symbola for emoji), never as "?"; what no installed
font draws is spelled in ASCII or refused by name; bidirectional controls never reorder a label
(U+202E drew "evil" as "live"): the spec refuses them, the text layer drops them from text that
came from elsewhere. Real fonts and real drawing throughout; a test needing a fallback font
skips, naming the Debian package, where it is not installed (.ci/run installs them)."""
import os
import re
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image, ImageDraw, ImageFont

from sdfpbr.errors import SpecError
from sdfpbr.image import layout, text
from sdfpbr.image.layout import Cell, chart_canvas, forget_layouts, label_boxes
from sdfpbr.image.text import (FALLBACK_FONTS, draw_text, drawable_text, load_font, text_bbox, text_length,
                               text_runs, wrap_text)
from sdfpbr.spec import load_spec, make_spec

CJK = "材料 テスト 한국어"
EMOJI = "🙂"
TITLE = f"{CJK} {EMOJI} mixed Latin"
FONTS = {package: path for path, package, _, _ in FALLBACK_FONTS}
CELLS = [Cell(r, c, 20.0 + 40 * c, 20.0 + 40 * r, 15.0) for r in range(2) for c in range(3)]


def needs_font(package: str) -> str:
    path = FONTS[package]
    if not os.path.isfile(path):
        pytest.skip(f"needs Debian's {package} (a fallback font), absent here: {path}")
    return path


def needs_main_font() -> None:
    if not os.path.isfile(text.SYSTEM_FONTS[0]):
        pytest.skip(f"needs Debian's fonts-dejavu-core, absent here: {text.SYSTEM_FONTS[0]}")


def drawn(s: str, font=None, anchor: str = "ls", size=(400, 60), xy=(10, 44), **kw) -> np.ndarray:
    """``s`` drawn white on black through text.draw_text: its coverage (uint8, H x W)."""
    image = Image.new("L", size, 0)
    draw_text(ImageDraw.Draw(image), xy, s, font or load_font(30), 255, anchor=anchor, **kw)
    return np.asarray(image)


def ink_box(mask: np.ndarray) -> tuple[int, int, int, int]:
    ys, xs = np.nonzero(mask)
    return int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1


def title_ink(title: str) -> np.ndarray:
    """The title's pixels as chart_canvas draws them (the real label layout), cut to its box."""
    forget_layouts()
    canvas, _ = chart_canvas((80, 120), CELLS, [0, 0.5, 1], [0, 1], title, "footer")
    (box,) = [b for t, b in label_boxes((80, 120), CELLS, [0, 0.5, 1], [0, 1], title, "footer")
              if t in (drawable_text(title, layout._styles(120)["title"].font),)]
    x0, y0, x1, y1 = (int(v) for v in (np.floor(box[0]), np.floor(box[1]), np.ceil(box[2]), np.ceil(box[3])))
    return canvas[y0:y1, x0:x1, :3].max(axis=2)


@pytest.fixture
def fonts_as_installed():
    """Each test that changes which fonts exist gets the machine's own back afterwards."""
    yield
    text.forget_fonts()
    layout._ink_box.cache_clear()
    layout._drawing_identity.cache_clear()
    forget_layouts()


# ---- fallback fonts ------------------------------------------------------------------------------

def test_cjk_and_emoji_are_drawn_from_the_fallback_fonts_not_as_question_marks():
    needs_main_font()
    wqy, symbola = needs_font("fonts-wqy-microhei"), needs_font("fonts-symbola")
    font = load_font(30)
    assert drawable_text(TITLE, font) == TITLE                       # nothing replaced by "?"
    fonts = {t.strip(): f.path for t, f in text_runs(TITLE, font) if t.strip()}
    assert fonts == {"材料 テスト 한국어": wqy, EMOJI: symbola, "mixed Latin": text.SYSTEM_FONTS[0]}
    # The glyphs are the fallback font's own: "材料" as draw_text sets it (in the chain of the
    # main font) is, pixel for pixel, Pillow drawing it in WenQuanYi Micro Hei.
    image = Image.new("L", (400, 60), 0)
    ImageDraw.Draw(image).text((10, 44), "材料", font=ImageFont.truetype(wqy, 30), fill=255, anchor="ls")
    np.testing.assert_array_equal(drawn("材料"), np.asarray(image))
    for s in ("材料", "テスト", EMOJI, TITLE):
        assert drawn(s).any() and not np.array_equal(drawn(s), drawn("?" * len(s))), s


def test_a_cjk_and_emoji_title_is_drawn_in_the_chart_layout():
    """The chart's own layout (measure, wrap, place, draw): the title's ink is not that of "??"
    and it is as wide as the text's runs measure."""
    needs_main_font()
    needs_font("fonts-wqy-microhei"), needs_font("fonts-symbola")
    for title in ("材料", "テスト", EMOJI, f"Gold 金 {EMOJI}"):
        ink, question = title_ink(title), title_ink("?" * len(title))
        assert ink.max() > 128, title
        assert ink.shape != question.shape or not np.array_equal(ink, question), title
    font = layout._styles(120)["title"].font
    width = title_ink(f"Gold 金 {EMOJI}").shape[1]
    assert abs(width - text_length(font, f"Gold 金 {EMOJI}")) <= 4


def test_text_bbox_is_the_ink_draw_text_puts_down_for_mixed_fonts():
    needs_main_font()
    needs_font("fonts-wqy-microhei"), needs_font("fonts-symbola")
    font = load_font(30)
    for anchor, xy in (("ls", (10, 44)), ("ms", (200, 44)), ("la", (10, 5)), ("mm", (200, 30))):
        mask = drawn(TITLE, anchor=anchor, size=(600, 60), xy=xy)
        left, top, right, bottom = text_bbox(font, TITLE, anchor=anchor)
        x0, y0, x1, y1 = ink_box(mask)
        assert xy[0] + left - 1 <= x0 and x1 <= xy[0] + right + 1, anchor
        assert xy[1] + top - 1 <= y0 and y1 <= xy[1] + bottom + 1, anchor
    # centred on a point ("ms": a sheet's title) the runs sit either side of it alike
    x0, _, x1, _ = ink_box(drawn("材料材料", anchor="ms", size=(600, 60), xy=(300, 44)))
    assert abs((x0 + x1) / 2 - 300) <= 2
    # outlined (a transparent chart's labels): the outline is drawn under every run's fill
    outlined = drawn(f"a{EMOJI}b材", stroke_width=2, stroke_fill=128)
    assert (outlined == 255).any() and (outlined == 128).any()


def test_wrapping_measures_the_fallback_runs():
    needs_main_font()
    needs_font("fonts-wqy-microhei")
    font = load_font(20)
    words = ["材料"] * 12
    lines = wrap_text(" ".join(words), font, 120)
    assert len(lines) > 1 and all(text_length(font, line) <= 120 for line in lines)
    assert " ".join(lines).split() == words


def test_emoji_presentation_selectors_and_joiners_draw_no_boxes():
    needs_main_font()
    needs_font("fonts-symbola")
    font = load_font(30)
    assert drawable_text("❤️", font) == "❤"                        # VS16: the one glyph there is
    family = drawable_text("👨\u200d👩\u200d👧", font)
    assert family.replace("\u200d", "") == "👨👩👧"
    np.testing.assert_array_equal(drawn(family), drawn("👨👩👧"))    # the joiners draw nothing


# ---- what no font draws ----------------------------------------------------------------------------

def test_a_character_no_installed_font_has_is_refused_by_name():
    font = load_font(30)
    with pytest.raises(SpecError) as caught:
        drawable_text("ok \ue000 \U000f0000", font)
    message = str(caught.value)
    assert "\n" not in message and "U+E000 (a private-use character)" in message
    assert "U+F0000" in message and "?" not in message.split(":", 1)[1].split(";")[0]
    with pytest.raises(SpecError, match=re.escape("U+E000")):   # and so in a chart title, before any drawing
        chart_canvas((80, 120), CELLS, [0, 0.5, 1], [0, 1], "title \ue000", "footer")


def test_without_the_fallback_fonts_cjk_is_refused_naming_the_package(tmp_path, monkeypatch, fonts_as_installed):
    """A machine without fonts-wqy-microhei and fonts-symbola (their files absent): a CJK or
    emoji title is refused, naming the characters and the package to install."""
    absent = tuple((str(tmp_path / f"absent-{os.path.basename(path)}"), package, name, what)
                   for path, package, name, what in FALLBACK_FONTS)
    monkeypatch.setattr(text, "FALLBACK_FONTS", absent)
    text.forget_fonts()
    font = load_font(30)
    with pytest.raises(SpecError) as caught:
        drawable_text("材料", font)
    assert "U+6750 CJK UNIFIED IDEOGRAPH-6750 (材)" in str(caught.value)
    assert "install Debian's fonts-wqy-microhei" in str(caught.value)
    with pytest.raises(SpecError, match=re.escape("U+1F642 SLIGHTLY SMILING FACE")
                                        + ".*install Debian's fonts-symbola"):
        drawable_text(f"ok {EMOJI}", font)


def test_pillows_own_font_still_spells_what_it_cannot_draw(tmp_path, monkeypatch, fonts_as_installed):
    """No DejaVu and no fallbacks (a bare machine): Pillow's embedded font, and the ASCII
    spellings of the characters the chart's own labels use."""
    monkeypatch.setattr(text, "SYSTEM_FONTS", (str(tmp_path / "absent.ttf"),))   # (no file of that name anywhere)
    monkeypatch.setattr(text, "FALLBACK_FONTS", ())
    text.forget_fonts()
    font = load_font(20)
    assert not isinstance(font.path, str)   # Pillow's own
    assert drawable_text("roughness r (α = r²)", font) == "roughness r (alpha = r^2)"
    assert drawable_text("Roughness × metallic — 5×5", font) == "Roughness x metallic - 5x5"
    assert drawable_text("Δ café", font) == "Delta cafe"
    assert wrap_text("α = r²", font, 1000) == ["alpha = r^2"]


# ---- bidirectional and control characters -----------------------------------------------------------

@pytest.mark.parametrize("title", ["\u202eevil", "ab\u202dc", "x\u2067y\u2069", "\u200fz", "a\u061cb", "a\x1b[31mb",
                                   "nul\x00", "c1\x85"])
def test_the_spec_refuses_bidi_and_control_characters_in_a_title(title):
    with pytest.raises(SpecError) as caught:
        make_spec(title=title)
    message = str(caught.value)
    bad = next(c for c in title if c in text.BIDI_CONTROLS or (ord(c) < 32 or 0x7f <= ord(c) < 0xa0))
    assert message.startswith("title must not contain") and f"U+{ord(bad):04X}" in message
    assert "\n" not in message and not any(c in text.BIDI_CONTROLS for c in message)


def test_a_title_keeps_its_line_breaks_and_tabs():
    assert make_spec(title="two\nlines\tand a tab").title == "two\nlines\tand a tab"


def test_a_spec_file_title_is_checked_alike(tmp_path):
    path = tmp_path / "spec.toml"
    path.write_text('title = "\\u202Eevil"\n')
    with pytest.raises(SpecError, match=re.escape("U+202E RIGHT-TO-LEFT OVERRIDE")):
        load_spec(path)


def test_bytes_that_were_not_utf8_are_drawn_as_the_replacement_character():
    """A command line's or file name's undecodable bytes (Python keeps them as lone surrogates)."""
    needs_main_font()
    assert drawable_text("caf\udce9.gltf", load_font(30)) == "caf\ufffd.gltf"


def test_a_right_to_left_override_title_exits_2_with_one_line_before_rendering(tmp_path):
    out = tmp_path / "out.png"
    r = subprocess.run([sys.executable, "-m", "sdfpbr", "chart", "--size", "128x128", "--title", "\u202eevil",
                        "-o", str(out)], capture_output=True, text=True, timeout=120)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2, r.stderr
    assert len(lines) == 1 and "U+202E RIGHT-TO-LEFT OVERRIDE" in lines[0], r.stderr
    assert "\u202e" not in r.stderr and not out.exists()


def test_bidi_controls_from_elsewhere_never_reorder_a_label():
    """Text that reaches the drawing without the spec's check (a glTF material's name, a file
    name in a footer): its bidi controls are dropped, so "\\u202eevil" draws as "evil"."""
    needs_main_font()
    font = load_font(30)
    assert drawable_text("\u202eevil", font) == "evil"
    assert drawable_text("a\u2066b\u2069\x1bc\td", font) == "abc d"
    evil = drawn(drawable_text("\u202eevil", font))
    np.testing.assert_array_equal(evil, drawn("evil"))
    assert not np.array_equal(evil, drawn("live"))
    # What drew "live" before: Pillow with libraqm applies the bidi algorithm to what it is given.
    from PIL import features
    if features.check("raqm"):
        raw = Image.new("L", (400, 60), 0)
        ImageDraw.Draw(raw).text((10, 44), "\u202eevil", font=font, fill=255, anchor="ls")
        np.testing.assert_array_equal(np.asarray(raw), drawn("live"))


# ---- the whole command -------------------------------------------------------------------------------

def test_sdfpbr_chart_draws_a_cjk_and_emoji_title(tmp_path):
    """`sdfpbr chart --title` end to end, small: the title band of the CJK and emoji chart is
    not that of a chart titled with as many question marks."""
    needs_main_font()
    needs_font("fonts-wqy-microhei"), needs_font("fonts-symbola")
    env = {**os.environ, "SDFPBR_CACHE_DIR": str(tmp_path / "cache")}
    bands = []
    for i, title in enumerate(("材料 テスト 🙂", "?? ??? ?")):
        out = tmp_path / f"chart{i}.png"
        r = subprocess.run([sys.executable, "-m", "sdfpbr", "chart", "--size", "128x128", "--quality", "draft",
                            "--title", title, "-o", str(out)], capture_output=True, text=True, timeout=300, env=env)
        if r.returncode == 3:
            pytest.skip(f"no OpenGL here: {r.stderr.strip()}")
        assert r.returncode == 0, r.stderr
        image = np.asarray(Image.open(out).convert("L"))
        bands.append(image[:40])
    assert bands[0].shape != bands[1].shape or not np.array_equal(*bands)
    assert (bands[0] > 128).any()
