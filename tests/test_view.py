"""`flexmbs view RESULTS`: one self-contained HTML page of a results file, turned and played in a browser.

The user's cases of issue 41: the three-bar mechanism run to its end (1,001 outputs) viewed as one page of
at most 5 MB that draws and animates offline, and a modes file whose modes are picked in the page.  The
scene's data are decoded here as the page decodes them and compared with the results file; the page
itself is opened in headless Chromium with the network cut off (skipped where there is no Chromium).
"""

from __future__ import annotations

import base64
import json
import re
import zlib

import h5py
import numpy as np
import pytest

from flexmbs.browser import chromium, open_page
from flexmbs.cli import main
from flexmbs.view import MODE_FRAMES, _Points, scene
from reference.io.results import load_results

from test_mode_animation import FREQUENCY, ROOT, results_file as modes_file

no_browser = pytest.mark.skipif(chromium() is None, reason="no chromium executable: install one to run the "
                                "browser checks (apt-get install chromium; README, 'Using it')")
DRAWN = ("(function(){var v = window.flexmbsViews && window.flexmbsViews[0]; if (!v || !v.ready) return false;"
         "var c = v.canvas, d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data, n = 0;"
         "for (var i = 0; i < d.length; i += 4) if (d[i] < 200 || d[i + 1] < 200 || d[i + 2] < 200) n++;"
         "return {inked: n, pixels: d.length / 4, drawn: v.drawn, frames: +v.slider.max + 1};})()")
"""Ready when the first view has drawn: its canvas's dark pixels (the model, the text and the axes' arrows)."""


def decoded(text: str, shape: tuple, dtype) -> np.ndarray:
    return np.frombuffer(zlib.decompress(base64.b64decode(text)), dtype=dtype).reshape(shape)


def positions(data: dict, k: int) -> np.ndarray:
    """Sequence k's points (frames, P, 3) as the page computes them: the differences summed modulo 2¹⁶, then
    dequantised on the box."""
    seq = data["sequences"][k]
    q = decoded(seq["positions"], (len(seq["times"]), data["points"], 3), "<u2").astype(np.uint64)
    q = np.cumsum(q, axis=0) % 65536
    lo, hi = np.array(data["box"][0]), np.array(data["box"][1])
    return lo + q * (hi - lo) / 65535.0


@pytest.fixture(scope="module")
def three_bar(tmp_path_factory):
    """The three-bar mechanism run to t_end as `flexmbs run` writes it (1,001 outputs)."""
    out = tmp_path_factory.mktemp("three_bar")
    assert main(["run", str(ROOT / "models" / "three_bar.toml"), "--out", str(out), "--no-vtk"]) == 0
    return out / "results.h5"


def test_three_bar_page_holds_every_output_within_quantisation(three_bar, tmp_path, capsys):
    page = tmp_path / "three_bar.html"
    assert main(["view", str(three_bar), "--out", str(page)]) == 0
    assert capsys.readouterr().out.startswith(f"wrote {page} (")
    text = page.read_text(encoding="utf-8")
    assert page.stat().st_size <= 5e6  # the bound for 1,001 outputs (measured 0.11 MB)
    # self-contained: no address to fetch, no script or style loaded from elsewhere
    assert not re.search(r"(src|href)\s*=\s*[\"']?(https?:)?//", text) and "import(" not in text
    data = json.loads(re.search(r'<script type="application/json">(.*?)</script>', text, re.S).group(1))
    r = load_results(three_bar)
    motion = data["sequences"][0]
    assert len(motion["times"]) == len(r.time) == 1001
    assert np.allclose(motion["times"], r.time, rtol=1e-6, atol=0)  # written to 6 significant digits
    # every point of every frame: the nodes' positions and the rigid bodies' points, turned with their bodies
    from flexmbs.plot import domain_of

    exact = _Points(domain_of(r)).of(r.positions, r.rotations)
    side = np.subtract(data["box"][1], data["box"][0])
    # 16-bit quantisation on the box: half a step, plus the round-off of the dequantisation
    assert np.all(np.abs(positions(data, 0) - exact) <= side / 65535 * (0.5 + 1e-6))
    # the coupler's nodes are drawn where the file has them
    coupler = [r.labels.index(f"coupler:{k}") for k in range(5)]
    assert np.all(np.abs(positions(data, 0)[:, :5] - r.positions[:, coupler]) <= side / 65535 * (0.5 + 1e-6))
    # colour by the bending moment M₂ of the coupler's elements: 8 bits on ±the largest magnitude
    m2 = motion["colours"]["M2"]
    values = np.asarray(r.section_moments)[:, :, 1]
    assert m2["scale"] == pytest.approx(np.abs(values).max(), rel=1e-12)
    level = decoded(m2["data"], values.shape, np.uint8)
    assert np.all(np.abs((level / 127.5 - 1.0) * m2["scale"] - values) <= m2["scale"] / 255 * (1 + 1e-9))
    assert data["kinds"].count(-1) == 6 and sorted(set(data["kinds"]) - {-1, -2, -3, -4}) == [0, 1, 2, 3]
    # each rigid body's axes start at its centre of mass and point along its body axes e₁, e₂, e₃ (the columns
    # of A(q)), 8 % of the model's size at t = 0 long
    from reference.rotation import EulerParameters

    segments, kinds = np.reshape(data["segments"], (-1, 2)), np.array(data["kinds"])
    size = np.linalg.norm(np.ptp(exact[0, :13], axis=0))  # beam nodes, the bars' centres and named points
    for b, body in enumerate(("crank", "rocker")):
        n = r.labels.index(body)
        for k in (0, 500, 1000):
            A = EulerParameters(r.rotations[k, n]).matrix()
            for axis in range(3):
                start, tip = segments[kinds == -2 - axis][b]
                assert np.allclose(exact[k, start], r.positions[k, n], rtol=0, atol=1e-12)
                assert np.allclose(exact[k, tip] - exact[k, start], 0.08 * size * A[:, axis], rtol=0, atol=1e-12)


def test_subsampled_view_keeps_the_last_output(three_bar):
    data = scene(three_bar, max_frames=200)
    times = data["sequences"][0]["times"]
    assert len(times) <= 200 and times[0] == 0.0 and times[-1] == pytest.approx(10.0, rel=1e-12)
    assert np.allclose(np.diff(times)[:-1], 0.06, rtol=1e-6)  # every 6th output of 0.01 s


@no_browser
def test_three_bar_draws_and_plays_offline(three_bar, tmp_path):
    page = tmp_path / "three_bar.html"
    assert main(["view", str(three_bar), "--out", str(page)]) == 0
    seen = open_page(page, ready=DRAWN)
    (tmp_path / "three_bar.png").write_bytes(seen.screenshot)
    assert seen.requests == [] and seen.errors == [], (seen.requests, seen.errors)
    # drawn: 4 coupler elements, the two rigid bars (3 segments each, one to their centre) and their axes;
    # a blank canvas has no dark pixel; the model covers well over 0.1 % of it
    assert seen.value["drawn"] == 4 + 6 + 6 and seen.value["frames"] == 1001
    assert seen.value["inked"] > 1e-3 * seen.value["pixels"]
    # the play button moves the time on, and the drawing with it
    played = open_page(page, ready="(function(v){if (!v || !v.ready) return false; if (!v.asked) {v.asked = 1; "
                       "v.play.click(); return false;} return v.frame > 20 && v.playing ? v.frame : false;})"
                       "(window.flexmbsViews && window.flexmbsViews[0])", screenshot=False)
    assert played.value > 20 and played.errors == []


@no_browser
def test_modes_are_picked_in_the_page(tmp_path):
    path, data = modes_file(tmp_path)
    page = tmp_path / "modes.html"
    assert main(["view", str(path), "--out", str(page)]) == 0
    shown = json.loads(re.search(r'<script type="application/json">(.*?)</script>', page.read_text("utf-8"),
                                 re.S).group(1))
    names = [s["name"] for s in shown["sequences"]]
    assert names == [f"mode 1: {FREQUENCY[0]:.4g} Hz", f"mode 2: {FREQUENCY[1]:.4g} Hz"]
    seen = open_page(page, ready="(function(v){if (!v || !v.ready) return false; if (!v.asked) {v.asked = 1; "
                     "v.chooser.value = '1'; v.chooser.dispatchEvent(new Event('change')); return false;} "
                     "return v.sequence === 1 && v.frame === " + str(MODE_FRAMES // 4) + " && "
                     "[v.chooser.options.length, v.drawn];})(window.flexmbsViews && window.flexmbsViews[0])")
    assert seen.value == [2, 4 + 3 + 3] and seen.errors == [] and seen.requests == []  # beam, bar (3), its axes


def test_mode_sequences_follow_the_shapes(tmp_path):
    path, data = modes_file(tmp_path)
    shown = scene(path)
    assert shown["kind"] == "modes" and len(shown["sequences"]) == 2  # one record: no static path to show
    from reference.io.mode_animation import amplitude, mode_history, read_mode
    from reference.io.vtk import Layout

    points = _Points(data["domain"])
    side = np.subtract(shown["box"][1], shown["box"][0])
    for k in (1, 2):
        mode = read_mode(path, k)
        # the amplitude of `flexmbs plot --mode`: about the configuration linearised about
        history = mode_history(mode, amplitude(Layout(data["domain"], mode["x0"], mode["q0"]), mode["q0"],
                                               mode["shape"]), MODE_FRAMES)
        exact = points.of(history.positions, history.rotations)
        assert np.all(np.abs(positions(shown, k - 1) - exact) <= side / 65535 * (0.5 + 1e-6)), k
        # a quarter period on, the beam's nodes are moved by the amplitude times the shape: not at rest
        assert np.ptp(exact[:, :5], axis=0).max() > 0.0


@pytest.mark.parametrize("case, message", [
    ("missing", "no such results file; give the results.h5 written by `flexmbs run` or `flexmbs modes`"),
    ("not hdf5", "not a flexmbs results file ("),
    ("no deck", "the file carries no deck, so the model's elements are unknown; write it with `flexmbs run DECK`"),
    ("no records", "the file has no records (status 'running'): its run ended before the first output"),
])
def test_unviewable_files_are_one_line(tmp_path, capsys, case, message):
    path = tmp_path / "results.h5"
    if case == "not hdf5":
        path.write_text("not a results file\n")
    elif case in ("no deck", "no records"):
        modes, _ = modes_file(tmp_path)
        with h5py.File(modes, "a") as f:
            if case == "no deck":
                f.attrs["deck"] = ""
            else:
                f.attrs["status"] = "running"
                for name in ("time", "nodes/position", "nodes/rotation"):
                    shape = f[name].shape
                    del f[name]
                    f.create_dataset(name, shape=(0, *shape[1:]), dtype="f8")
    assert main(["view", str(path)]) == 2
    err = capsys.readouterr().err
    assert err == f"flexmbs: error: {path}: {message}" + err.split(message, 1)[1] and err.count("\n") == 1, err


def test_report_embeds_each_deck_view_and_the_script_once(three_bar, tmp_path):
    from flexmbs.html import markdown_to_html
    from flexmbs.report import view_lines
    from reference.io.deck import load_deck

    deck = load_deck(ROOT / "models" / "three_bar.toml")
    lines = view_lines(three_bar, tmp_path / "views" / "three_bar.html", deck)
    assert lines[0].startswith("[Interactive 3D view of three_bar](views/three_bar.html): drag to turn it, play it")
    page = (tmp_path / "views" / "three_bar.html").read_text(encoding="utf-8")
    data = json.loads(re.search(r'<script type="application/json">(.*?)</script>', page, re.S).group(1))
    assert len(data["sequences"][0]["times"]) <= 200  # flexmbs.view.EMBEDDED_FRAMES: every 6th of 1,001
    report = markdown_to_html("\n".join(["# report", "## 1. Three bar", *lines, "## 2. The same again", *lines]),
                              tmp_path)
    assert report.count('<div class="flexmbs-view">') == 2 and report.count('"use strict"') == 1
    assert '<a href="views/three_bar.html">Interactive 3D view of three_bar</a>' in report
    if chromium() is None:
        pytest.skip("no chromium executable: the embedded views were not opened (apt-get install chromium)")
    (tmp_path / "report.html").write_text(report, encoding="utf-8")
    seen = open_page(tmp_path / "report.html", ready="window.flexmbsViews && window.flexmbsViews.length === 2 && "
                     "window.flexmbsViews.every(function (v) { return v.ready; }) && "
                     "window.flexmbsViews.map(function (v) { return v.drawn; })", screenshot=False)
    assert seen.value == [16, 16] and seen.errors == [] and seen.requests == []


def test_docs_gallery_and_report_page_draw_the_committed_views(tmp_path):
    from flexmbs import site

    views = sorted(p.stem for p in site.VIEWS.glob("*.html") if (ROOT / "models" / f"{p.stem}.toml").exists())
    assert "three_bar" in views and "cantilever_modes" in views  # written by `flexmbs report` (reports/views/)
    page = site.gallery(tmp_path)
    assert page.count('<div class="flexmbs-view">') == len(views) and page.count('"use strict"') == 1
    # every view is one line of raw HTML followed by a blank line: a Markdown HTML block ends there
    for line in page.splitlines():
        if line.startswith('<div class="flexmbs-view">'):
            assert line.endswith("</script></div>")
    markdown = "Text.\n[Interactive 3D view of three_bar](views/three_bar.html): drag to turn it.\n"
    embedded = site._views_in_place(markdown, site.VIEWS.parent)
    assert embedded.count('<div class="flexmbs-view">') == 1 and "(views/three_bar.html)" not in embedded
    assert "Interactive 3D view of three_bar: drag to turn it." in embedded
