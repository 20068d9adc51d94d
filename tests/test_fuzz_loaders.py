"""Property-based fuzzing of the three loaders a stranger's file reaches first: the spec
loader, the home loader and the URDF importer. Inputs are the valid examples, mutated; every
result must be a model or an InputError (one line for the command line), never another
exception, and no YAML tag may run code.

About 30 s by default (a fixed seed, so CI is repeatable); `HOMEMODEL_FUZZ=long` runs a
longer, random profile (`HOMEMODEL_FUZZ_EXAMPLES` sets its size)."""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path
from typing import NamedTuple

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from sample_house import cupboard_model

from homemodel.app.home.build import load_home
from homemodel.core.errors import InputError
from homemodel.exchange.model_files import export_model
from homemodel.exchange.urdf.read import load_urdf
from modeller import load_spec

REPO = Path(__file__).resolve().parents[1]
LONG = os.environ.get("HOMEMODEL_FUZZ") == "long"
EXAMPLES = int(os.environ.get("HOMEMODEL_FUZZ_EXAMPLES", 5000 if LONG else 150))
FUZZ = settings(
    max_examples=EXAMPLES, deadline=None, derandomize=not LONG, database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
MARKER = Path("/tmp/homemodel-fuzz-ran-code")

SPECIAL_SCALARS = [
    "nan", ".nan", ".inf", "-.inf", "1e300", "-1e300", "1e-320", "0", "-1", "101", "[]", "{}", "null", "~", "''",
    "yes", "on", "0x1F", "1_000", "2001-12-14", "*anchor", "&anchor 1", "!!binary AAAA", "!!set {a}",
    f"!!python/object/apply:os.mkdir ['{MARKER}']", "!!python/name:os.system", "[[[[[[[[[[1]]]]]]]]]]",
    "'" + "x" * 5000 + "'", "/etc/passwd", "../../outside.yaml", "file:///etc/hostname", "\"\\u0000\"",
]
SPECIAL_XML = [
    "nan", "inf", "-inf", "1e300", "-1e300", "", " ", "1 2", "1 2 3 4", "a b c", "0 0 0", "-1",
    "../../../etc/passwd", "/dev/zero", "file:///etc/hostname", "package://x/meshes/body.obj", "meshes",
    "revolute", "continuous", "prismatic", "floating", "planar", "fixed", "&amp;", "\u00e9", "1e-320",
]
YAML_NOISE = st.text(alphabet=list(":-[]{}&*!|>'\"#,\n 0123456789.e+naif?%@`\t\\"), max_size=24)
XML_NOISE = st.text(alphabet=list("<>/=\"' abcdefghijklmnopqrstuvwxyz0123456789.-\n&;!?[]"), max_size=24)


@st.composite
def mutated(draw, text: str, specials: list[str], noise, value_pattern: str) -> str:
    """`text` after 1 to 4 edits: a value swapped for a special one, a span replaced by noise,
    a line deleted or repeated, an element or mapping nested, or a cut at a random point."""
    for _ in range(draw(st.integers(1, 4))):
        lines = text.splitlines(keepends=True)
        kind = draw(st.sampled_from(["value", "value", "noise", "delete", "repeat", "cut", "nest"]))
        if kind == "value":
            values = list(re.finditer(value_pattern, text))
            if values:
                match = draw(st.sampled_from(values))
                text = text[: match.start(1)] + draw(st.sampled_from(specials)) + text[match.end(1):]
        elif kind == "noise":
            start = draw(st.integers(0, len(text)))
            end = draw(st.integers(start, min(len(text), start + 20)))
            text = text[:start] + draw(noise) + text[end:]
        elif kind in ("delete", "repeat") and lines:
            i = draw(st.integers(0, len(lines) - 1))
            lines[i:i + 1] = [] if kind == "delete" else [lines[i]] * draw(st.integers(2, 50))
            text = "".join(lines)
        elif kind == "cut":
            text = text[: draw(st.integers(0, len(text)))]
        else:
            depth = draw(st.integers(1, 200))
            start = draw(st.integers(0, len(text)))
            text = text[:start] + ("[" * depth + "]" * depth if "<" not in text else "<a>" * depth + "</a>" * depth) + text[start:]
    return text


def _expect_model_or_input_error(load, path: Path) -> None:
    try:
        load(path)
    except InputError:
        pass
    assert not MARKER.exists(), f"a YAML tag ran code: {path.read_text()[:2000]}"


YAML_VALUE = r":[ \t]+([^\s#\[\]{},][^\n#\[\]{},]*)"
SPECS = sorted((REPO / "examples" / "catalogue").glob("*.yaml")) + sorted((REPO / "examples" / "textured").glob("*.yaml"))


@pytest.fixture(scope="module")
def spec_folder(tmp_path_factory) -> Path:
    """The catalogue and textured examples (with their photos), copied to be overwritten."""
    folder = tmp_path_factory.mktemp("specs")
    shutil.copytree(REPO / "examples" / "textured" / "photos", folder / "photos")
    return folder


@FUZZ
@given(data=st.data())
def test_the_spec_loader_returns_a_spec_or_an_input_error(spec_folder: Path, data) -> None:
    source = data.draw(st.sampled_from(SPECS))
    path = spec_folder / "spec.yaml"
    path.write_text(data.draw(mutated(source.read_text(), SPECIAL_SCALARS, YAML_NOISE, YAML_VALUE)))
    _expect_model_or_input_error(load_spec, path)


@pytest.fixture(scope="module")
def home_folder(tmp_path_factory, kitchen_dir: Path) -> Path:
    folder = tmp_path_factory.mktemp("home") / "kitchen"
    shutil.copytree(kitchen_dir, folder)
    return folder


@FUZZ
@given(data=st.data())
def test_the_home_loader_returns_a_home_or_an_input_error(home_folder: Path, kitchen_dir: Path, data) -> None:
    text = (kitchen_dir / "home.yaml").read_text()
    (home_folder / "home.yaml").write_text(data.draw(mutated(text, SPECIAL_SCALARS, YAML_NOISE, YAML_VALUE)))
    _expect_model_or_input_error(load_home, home_folder)


@pytest.fixture(scope="module")
def urdf_folder(tmp_path_factory) -> tuple[Path, str]:
    """An exported cupboard (links, a hinge, a knob, meshes) and its URDF's text."""
    folder = export_model(cupboard_model(), tmp_path_factory.mktemp("urdf") / "cupboard")
    return folder, (folder / "model.urdf").read_text()


@FUZZ
@given(data=st.data())
def test_the_urdf_importer_returns_a_model_or_an_input_error(urdf_folder: tuple[Path, str], data) -> None:
    folder, text = urdf_folder
    path = folder / "fuzzed.urdf"
    path.write_text(data.draw(mutated(text, SPECIAL_XML, XML_NOISE, r'="([^"]*)"')))
    _expect_model_or_input_error(load_urdf, path)


def _one_line_error(result, capfd, *fragments: str) -> None:
    """Exit 2 and one line on stderr, counting what C code wrote to file descriptor 2."""
    c_stderr = capfd.readouterr().err
    assert result.exit_code == 2, result.output
    lines = (result.stderr + c_stderr).splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


class NoisePngs(NamedTuple):
    colour: bytes
    depth: bytes

    def __repr__(self) -> str:  # hypothesis prints the fixtures of a failing example
        return f"NoisePngs({len(self.colour)} and {len(self.depth)} bytes)"


@pytest.fixture(scope="module")
def noise_pngs() -> NoisePngs:
    """A 640x480 colour PNG and a 16-bit depth PNG of noise (large enough for libpng to read
    them in many chunks, so a cut lands mid-stream)."""
    import cv2
    import numpy as np

    rng = np.random.default_rng(0)
    colour = cv2.imencode(".png", rng.integers(0, 256, (480, 640, 3), dtype=np.uint8))[1].tobytes()
    depth = cv2.imencode(".png", rng.integers(500, 900, (480, 640), dtype=np.uint16))[1].tobytes()
    return NoisePngs(colour, depth)


@FUZZ
@given(cut=st.floats(0.0, 0.999), flip=st.booleans(), flags=st.sampled_from([None, -1]))
def test_a_truncated_or_corrupt_png_is_an_input_error_and_nothing_on_stderr(
    noise_pngs: NoisePngs, tmp_path: Path, capfd, cut, flip, flags
) -> None:
    from homemodel.core.images import read_image

    capfd.readouterr()
    data = bytearray(noise_pngs.colour if flags is None else noise_pngs.depth)
    if flip:  # a flipped bit somewhere past the signature, else a cut
        data[8 + int((len(data) - 9) * cut)] ^= 0x10
    else:
        del data[int(len(data) * cut) :]
    path = tmp_path / "bad.png"
    path.write_bytes(bytes(data))
    with pytest.raises(InputError, match="bad.png: not a readable image"):
        read_image(path, flags)
    assert capfd.readouterr().err == ""


def test_a_capture_of_truncated_pngs_is_one_line_of_error(noise_pngs, tmp_path: Path, capfd) -> None:
    from typer.testing import CliRunner

    from homemodel.cli import app
    from homemodel.geometry.camera import Camera, save_camera
    from turntable.board import grid_board, save_board

    capture = tmp_path / "capture"
    (capture / "color").mkdir(parents=True)
    (capture / "depth").mkdir()
    save_camera(Camera(width=640, height=480, fx=600, fy=600, cx=319.5, cy=239.5, depth_scale_m=0.001), capture / "camera.yaml")
    save_board(grid_board(table_diameter_m=0.3, tag_size_m=0.03), capture / "board.yaml")
    colour, depth = noise_pngs
    for k, cut in enumerate((0.1, 0.4, 0.7, 0.95, 0.999)):
        (capture / "color" / f"{k:06d}.png").write_bytes(colour[: int(len(colour) * cut)])
        (capture / "depth" / f"{k:06d}.png").write_bytes(depth[: int(len(depth) * cut)])
    capfd.readouterr()
    result = CliRunner().invoke(app, ["turntable", "reconstruct", str(capture), "--out", str(tmp_path / "out")])
    _one_line_error(result, capfd, "only 0 of 5 frames", "000000.png: not a readable image")
    assert not (tmp_path / "out").exists()


def test_a_completion_library_with_an_empty_class_is_refused(tmp_path: Path, capfd) -> None:
    from typer.testing import CliRunner

    from homemodel.cli import app

    runner = CliRunner()
    result = runner.invoke(app, ["completion", "library", "--classes", "cup", "--per-class", "2", "--out", str(tmp_path / "lib")])
    assert result.exit_code == 0, result.output
    (tmp_path / "lib" / "bowl").mkdir()
    (tmp_path / "lib" / "bowl" / "notes.txt").write_text("the bowls are still on the other disk")
    capfd.readouterr()
    result = runner.invoke(app, ["completion", "train", str(tmp_path / "lib"), "--out", str(tmp_path / "model.npz")])
    _one_line_error(result, capfd, "lib/bowl: an empty class")
    assert not (tmp_path / "model.npz").exists()

    result = runner.invoke(app, ["completion", "library", "--classes", " , ", "--out", str(tmp_path / "none")])
    _one_line_error(result, capfd, "no classes to write")
    assert not (tmp_path / "none").exists()
