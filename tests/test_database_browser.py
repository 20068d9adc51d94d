"""`homemodel db serve` in a real browser (Debian's chromium through Selenium), on two
databases: a real build of two PartNet-style cupboards (the door's slider moves the door node
exactly as the glTF's extras.joint says, a fast second choice draws the second model, old
models are freed, nothing is drawn while idle, keyboard and `#id` links, the layout at
1,024 px), and 10,000 synthetic rows with script injected into every index field (nothing
runs; the list and a search are timed)."""

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

from homemodel.app.database import DatabaseBuildOptions, EntryRow, ModelIndex, build_database
from homemodel.app.database.server import ServeOptions, make_server
from homemodel.core.transforms import axis_angle_transform

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not shutil.which("chromedriver"), reason="needs Debian's chromium-driver (make setup)"),
]
ROWS = 10_000
# Each payload, if it ever became HTML or script, records the field it came through.
PAYLOADS = (
    '<img src=x onerror="window.pwned=(window.pwned||[]).concat(\'{f}\')">',
    "<script>window.pwned=(window.pwned||[]).concat('{f}')</script>",
    '"><svg onload="window.pwned=(window.pwned||[]).concat(\'{f}\')">',
    "javascript:window.pwned=(window.pwned||[]).concat('{f}')",
)


def _serve(db: Path, map_path: Path | None = None):  # noqa: ANN202
    server = make_server(db, ServeOptions(port=0), map_path=map_path)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server


@pytest.fixture(scope="module")
def driver():  # noqa: ANN201
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = shutil.which("chromium")
    for argument in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=1400,1000", "--enable-unsafe-swiftshader"):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    chrome = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=options)
    try:
        yield chrome
    finally:
        chrome.quit()


@pytest.fixture(scope="module")
def built(tmp_path_factory):  # noqa: ANN201
    root = tmp_path_factory.mktemp("browser")
    for name in ("cabinet", "locker"):
        write_partnet_cabinet(root / name)
    entries = [{"id": "cabinet", "source": "urdf", "path": "cabinet"}, {"id": "locker", "source": "urdf", "path": "locker", "category": "locker"}]
    (root / "manifest.yaml").write_text(yaml.safe_dump({"entries": entries}))
    db = root / "db"
    # Two imports on 2 processes: built in this process, with no cluster to start.
    build_database(root / "manifest.yaml", db, DatabaseBuildOptions(workers=2, repair=True))
    from homemodel.exchange.map_xml import save_map
    from homemodel.model_folder.map_entry import MapEntry, add_model_folder
    from semantic_map import SemanticMap
    from semantic_map.nodes import ParkingPosition

    smap = SemanticMap.new(apartment_id="flat", name="Flat")
    smap.add_room(room_id="kitchen", name="Kitchen")
    save_map(smap, root / "map.xml")
    parking = [ParkingPosition(name="front", world_from_base=np.eye(4), default=True)]
    add_model_folder(db / "models/cabinet", MapEntry(map_path=root / "map.xml", object_id="kitchen_cupboard", parent_id="kitchen", parking_positions=parking))
    server = _serve(db, root / "map.xml")
    yield f"http://127.0.0.1:{server.port}/", db
    server.shutdown()


@pytest.fixture
def page(driver, built):  # noqa: ANN201
    url, db = built
    driver.set_window_size(1400, 1000)
    driver.get(url)
    _until(driver, "return window.homemodel && window.homemodel.listed")
    return driver, db, url


def _until(driver, script: str, timeout_s: float = 60.0) -> None:  # noqa: ANN001
    deadline = time.monotonic() + timeout_s
    while not driver.execute_script(script):
        assert time.monotonic() < deadline, f"timed out waiting for {script}"
        time.sleep(0.05)


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


IDS = "return [...document.querySelectorAll('#models tbody tr')].map(r => r.dataset.id)"


def test_search_open_a_cupboard_and_move_its_door(page) -> None:
    driver, db, _ = page
    assert driver.execute_script(IDS) == ["cabinet", "locker"]
    driver.find_element("id", "search").send_keys("cupboard")
    _until(driver, "return window.homemodel.shown.q === 'cupboard'")
    assert driver.execute_script(IDS) == ["cabinet"]
    driver.find_element("css selector", 'tr[data-id="cabinet"]').click()
    _until(driver, "return window.homemodel.ready && window.homemodel.drawn === 'cabinet'")
    assert "PASS  check_urdf" in driver.find_element("id", "report").text
    slider = driver.find_element("css selector", 'input[data-joint="joint_0"]')
    # The slider snaps to its step; the door must follow the value it shows.
    q = driver.execute_script(
        "arguments[0].value = 1.0; arguments[0].dispatchEvent(new Event('input')); return Number(arguments[0].value)", slider
    )
    assert q == pytest.approx(1.0, abs=0.01)
    got = driver.execute_script("const n = window.homemodel.joints['joint_0']; n.updateMatrix(); return n.matrix.elements")
    node = _glb_nodes(db / "models/cabinet/model.glb")["link_0"]
    joint = node["extras"]["joint"]
    assert joint["type"] == "revolute" and joint["lower"] <= q <= joint["upper"]
    expected = _node_matrix(node) @ axis_angle_transform(joint["axis"], q)
    np.testing.assert_allclose(np.array(got).reshape(4, 4).T, expected, atol=1e-6)
    assert not np.allclose(expected, _node_matrix(node), atol=1e-3)  # it did move
    markers = "return window.homemodel.joints['joint_0'].children.filter(c => c.name.startsWith('grasp:')).length"
    assert driver.execute_script(markers) == 1  # the handle's grasp point rides on the door
    assert driver.current_url.endswith("#cabinet")
    driver.save_screenshot(str(db / "page.png"))  # the README's picture


def test_a_fast_second_choice_draws_the_second_model_and_frees_the_first(page) -> None:
    driver, _, _ = page
    driver.find_element("css selector", 'tr[data-id="locker"]').click()
    _until(driver, "return window.homemodel.ready && window.homemodel.drawn === 'locker'")
    memory = "return {...window.homemodel.memory()}"
    once = driver.execute_script(memory)
    for _ in range(3):  # the second click lands before the first model has loaded
        driver.execute_script(
            "const rows = document.querySelectorAll('#models tbody tr'); rows[0].click(); rows[1].click();"
        )
        _until(driver, "return window.homemodel.ready")
        assert driver.execute_script("return [window.homemodel.chosen, window.homemodel.drawn]") == ["locker", "locker"]
    assert driver.find_element("id", "title").text.startswith("locker")
    assert driver.execute_script(memory) == once  # geometries and textures of dropped loads freed
    # Nothing is drawn while nothing changes.
    frames = driver.execute_script("return window.homemodel.frames")
    time.sleep(1.0)
    assert driver.execute_script("return window.homemodel.frames") == frames


def test_keyboard_and_id_links(page) -> None:
    driver, _, url = page
    driver.execute_script("document.querySelector('#models tbody tr').focus()")
    from selenium.webdriver.common.keys import Keys

    driver.switch_to.active_element.send_keys(Keys.ARROW_DOWN)
    driver.switch_to.active_element.send_keys(Keys.ENTER)
    _until(driver, "return window.homemodel.ready && window.homemodel.drawn === 'locker'")
    driver.get(url + "#cabinet")
    _until(driver, "return window.homemodel.ready && window.homemodel.drawn === 'cabinet'")
    driver.get(url + "#no_such_model")
    _until(driver, "return window.homemodel.ready")
    assert "no model no_such_model" in driver.find_element("id", "message").text


def test_the_map_tree_links_objects_to_their_models(page) -> None:
    driver, _, _ = page
    _until(driver, "return !document.getElementById('map').hidden")
    driver.find_element("link text", "kitchen_cupboard").click()
    _until(driver, "return window.homemodel.ready && window.homemodel.drawn === 'cabinet'")


def test_layout_at_1024_px(page, tmp_path: Path) -> None:
    driver, db, _ = page
    driver.set_window_size(1024, 768)
    driver.find_element("css selector", 'tr[data-id="cabinet"]').click()
    _until(driver, "return window.homemodel.ready && window.homemodel.drawn === 'cabinet'")
    time.sleep(0.3)
    boxes = driver.execute_script(
        "const r = (id) => document.getElementById(id).getBoundingClientRect().toJSON();"
        "return {table: r('models'), viewer: r('viewer'), width: document.documentElement.clientWidth,"
        " scroll: document.documentElement.scrollWidth,"
        " detail: [document.getElementById('detail').scrollWidth, document.getElementById('detail').clientWidth]}"
    )
    assert boxes["detail"][0] <= boxes["detail"][1], boxes  # no sideways scrolling in the view's column
    assert boxes["table"]["right"] <= boxes["viewer"]["left"], boxes  # side by side, no overlap
    assert boxes["viewer"]["right"] <= boxes["width"] and boxes["scroll"] <= boxes["width"], boxes
    assert boxes["viewer"]["width"] > 400 and boxes["table"]["width"] > 400, boxes
    driver.save_screenshot(str(db / "page_1024.png"))
    driver.set_window_size(1400, 1000)


def test_no_console_errors(page) -> None:
    driver, _, _ = page
    driver.find_element("css selector", 'tr[data-id="cabinet"]').click()
    _until(driver, "return window.homemodel.ready && window.homemodel.drawn === 'cabinet'")
    errors = [entry for entry in driver.get_log("browser") if entry["level"] == "SEVERE" and "no_such_model" not in entry["message"]]
    assert errors == []


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):  # noqa: ANN201
    """10,000 rows, and rows with a payload in every field the index has."""
    db = tmp_path_factory.mktemp("synthetic") / "db"
    with ModelIndex(db, create=True) as index:
        for i in range(ROWS):
            row = EntryRow(id=f"base_unit_{i}", category="cupboard", source="spec", key="k", status=("valid", "invalid")[i % 2], triangles=i)
            index.put(row, commit=False)
        for n, payload in enumerate(PAYLOADS):
            p = lambda f: payload.format(f=f)  # noqa: E731
            row = EntryRow(
                id=p("id"), category=p("category"), source=p("source"), key=p("key"), status=p("status"),
                checks=[{"name": p("check name"), "passed": False, "detail": p("check detail")}], built_at=p("built_at"),
                error=p("error"), path=f"models/{p('path')}", thumbnail=f"models/{p('thumbnail')}.png",
                inputs={p("input role"): p("input")}, properties={p("property name"): p("property value")},
                repairs=[p("repair")], worker=p("worker"), times_s={p("stage"): 1.0},
            )  # fmt: skip
            index.put(row, commit=False)
            index._conn.execute(  # text where numbers belong, as a hand-edited index may hold
                "UPDATE models SET links = ?, joints = ?, grasp_points = ?, triangles = ?, build_s = ? WHERE id = ?",
                (p("links"), p("joints"), p("grasp_points"), p("triangles"), p("build_s"), row.id),
            )
        index.commit()
    server = _serve(db)
    yield f"http://127.0.0.1:{server.port}/"
    server.shutdown()


def test_injected_script_in_every_field_runs_nothing(driver, synthetic) -> None:
    driver.get(synthetic)
    _until(driver, "return window.homemodel && window.homemodel.listed")
    driver.find_element("id", "search").send_keys("pwned")
    _until(driver, "return window.homemodel.shown.q === 'pwned'")
    rows = driver.find_elements("css selector", "#models tbody tr")
    assert len(rows) == len(PAYLOADS)
    for index in range(len(PAYLOADS)):
        driver.find_elements("css selector", "#models tbody tr")[index].click()
        _until(driver, "return window.homemodel.ready")
        facts = driver.find_element("id", "facts").text + driver.find_element("id", "report").text
        assert "property name" in facts and "check detail" in facts  # shown, as text
    time.sleep(0.5)
    assert driver.execute_script("return window.pwned === undefined")
    live = "return [...document.querySelectorAll('*')].filter(e => [...e.attributes].some(a => a.name.startsWith('on'))).length"
    assert driver.execute_script(live) == 0
    assert driver.execute_script("return document.querySelectorAll('body script, body svg, td img:not([src^=\"/db/\"])').length") == 0
    cells = driver.execute_script("return [...document.querySelectorAll('#models tbody td')].map(t => t.textContent)")
    assert any(c.startswith("<script>") for c in cells) and any(c.startswith("<img src=x") for c in cells)  # as text


def test_10000_rows_list_and_search_quickly(driver, synthetic) -> None:
    driver.get(synthetic)
    _until(driver, "return window.homemodel && window.homemodel.listed")
    listed_s = driver.execute_script("return window.homemodel.listedMs") / 1000  # from the navigation's start
    assert driver.execute_script("return window.homemodel.shown.matched") == ROWS + len(PAYLOADS)
    ids = driver.execute_script(IDS)
    assert len(ids) == 100 and [i for i in ids if i.startswith("base_unit")][:11] == [f"base_unit_{i}" for i in range(11)]
    search = driver.find_element("id", "search")
    started = time.monotonic()
    search.send_keys("base_unit_999")
    _until(driver, "return window.homemodel.shown.q === 'base_unit_999'")
    search_s = time.monotonic() - started
    assert driver.execute_script(IDS) == ["base_unit_999", *(f"base_unit_999{i}" for i in range(10))]
    api_ms = driver.execute_script(
        "return performance.getEntriesByType('resource').filter(e => e.name.includes('q=base')).map(e => e.duration)"
    )
    # The debounce sends one query for the typed word, not one per key.
    assert 1 <= len(api_ms) <= 3, api_ms
    driver.find_element("id", "status").send_keys("invalid")
    _until(driver, "return window.homemodel.shown.status === 'invalid'")
    assert set(driver.execute_script("return [...document.querySelectorAll('#models tbody td:nth-child(5)')].map(t => t.textContent)")) == {"invalid"}
    # The 3D view stays in sight when the list is scrolled to its end.
    driver.execute_script("window.scrollTo(0, document.body.scrollHeight)")
    time.sleep(0.2)
    top = driver.execute_script("return document.getElementById('viewer').getBoundingClientRect().top")
    assert 0 <= top < 200
    # Loose bounds for a shared machine: the aims are 1 s and 50 ms.
    assert listed_s < 5.0 and max(api_ms) < 300 and search_s < 3.0, (listed_s, api_ms, search_s)
