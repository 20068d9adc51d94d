"""`homemodel db serve` in a real browser (Debian's chromium through Selenium): the page loads
without console errors, the search filters, a cupboard opens in the 3D view, and its door's
slider moves the door node exactly as the glTF's extras.joint says; the map tree links to it."""

from __future__ import annotations

import json
import shutil
import struct
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from partnet_sample import write_partnet_cabinet

from homemodel.app.database import DatabaseBuildOptions, build_database
from homemodel.app.database.server import make_server
from homemodel.core.transforms import axis_angle_transform

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not shutil.which("chromedriver"), reason="needs Debian's chromium-driver (make setup)"),
]


@pytest.fixture(scope="module")
def page(tmp_path_factory):  # noqa: ANN201
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    root = tmp_path_factory.mktemp("browser")
    for name in ("cabinet", "locker"):
        write_partnet_cabinet(root / name)
    entries = [{"id": "cabinet", "source": "urdf", "path": "cabinet"}, {"id": "locker", "source": "urdf", "path": "locker", "category": "locker"}]
    (root / "manifest.yaml").write_text(yaml.safe_dump({"entries": entries}))
    db = root / "db"
    build_database(root / "manifest.yaml", db, DatabaseBuildOptions(workers=1, repair=True))
    from semantic_map import SemanticMap, add_model_folder, save_map
    from semantic_map.model_folder import MapEntry
    from semantic_map.nodes import ParkingPosition

    smap = SemanticMap.new(apartment_id="flat", name="Flat")
    smap.add_room(room_id="kitchen", name="Kitchen")
    save_map(smap, root / "map.xml")
    parking = [ParkingPosition(name="front", world_from_base=np.eye(4), default=True)]
    add_model_folder(db / "models/cabinet", MapEntry(map_path=root / "map.xml", object_id="kitchen_cupboard", parent_id="kitchen", parking_positions=parking))

    server = make_server(db, port=0, map_path=root / "map.xml")
    threading.Thread(target=server.serve_forever, daemon=True).start()
    options = Options()
    options.binary_location = shutil.which("chromium")
    for argument in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=1400,1000", "--enable-unsafe-swiftshader"):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=options)
    driver.get(f"http://127.0.0.1:{server.server_address[1]}/")
    try:
        yield driver, db
    finally:
        driver.quit()
        server.shutdown()
        server.server_close()


def _until(driver, script: str, timeout_s: float = 60.0) -> None:  # noqa: ANN001
    deadline = time.monotonic() + timeout_s
    while not driver.execute_script(script):
        assert time.monotonic() < deadline, f"timed out waiting for {script}"
        time.sleep(0.1)


def _glb_nodes(path: Path) -> dict[str, dict]:
    data = path.read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    return {node["name"]: node for node in json.loads(data[20 : 20 + length])["nodes"]}


def _node_matrix(node: dict) -> np.ndarray:
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    matrix = np.eye(4)
    matrix[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    matrix[:3, 3] = node.get("translation", [0, 0, 0])
    return matrix


def test_search_open_a_cupboard_and_move_its_door(page) -> None:
    driver, db = page
    _until(driver, "return window.homemodel && window.homemodel.listed")
    ids = "return [...document.querySelectorAll('#models tbody tr')].map(r => r.dataset.id)"
    assert driver.execute_script(ids) == ["cabinet", "locker"]
    driver.find_element("id", "search").send_keys("cupboard")
    assert driver.execute_script(ids) == ["cabinet"]
    driver.find_element("css selector", 'tr[data-id="cabinet"]').click()
    _until(driver, "return window.homemodel.ready && window.homemodel.chosen === 'cabinet'")
    assert "PASS  check_urdf" in driver.find_element("id", "report").text
    slider = driver.find_element("css selector", 'input[data-joint="joint_0"]')
    # The slider snaps to its step; the door must follow the value it shows.
    q = driver.execute_script(
        "arguments[0].value = 1.0; arguments[0].dispatchEvent(new Event('input')); return Number(arguments[0].value)", slider
    )
    assert q == pytest.approx(1.0, abs=0.01)
    got = driver.execute_script(
        "const n = window.homemodel.joints['joint_0']; n.updateMatrix(); return n.matrix.elements"
    )
    node = _glb_nodes(db / "models/cabinet/model.glb")["link_0"]
    joint = node["extras"]["joint"]
    assert joint["type"] == "revolute" and joint["lower"] <= q <= joint["upper"]
    expected = _node_matrix(node) @ axis_angle_transform(joint["axis"], q)
    np.testing.assert_allclose(np.array(got).reshape(4, 4).T, expected, atol=1e-6)
    assert not np.allclose(expected, _node_matrix(node), atol=1e-3)  # it did move
    markers = "return window.homemodel.joints['joint_0'].children.filter(c => c.name.startsWith('grasp:')).length"
    assert driver.execute_script(markers) == 1  # the handle's grasp point rides on the door
    driver.save_screenshot(str(db / "page.png"))


def test_the_map_tree_links_objects_to_their_models(page) -> None:
    driver, _ = page
    _until(driver, "return window.homemodel && window.homemodel.listed")
    link = driver.find_element("link text", "kitchen_cupboard")
    link.click()
    _until(driver, "return window.homemodel.ready && window.homemodel.chosen === 'cabinet'")


def test_no_console_errors(page) -> None:
    driver, _ = page
    _until(driver, "return window.homemodel && window.homemodel.listed")
    errors = [entry for entry in driver.get_log("browser") if entry["level"] == "SEVERE"]
    assert errors == []
