"""Scene loading, overrides, validation and the resolved listing (nld/model/scene.py)."""
from __future__ import annotations

import copy
import math
import tomllib

import pytest

from nld.errors import InputError, SceneError
from nld.model.scene import (apply_overrides, builtin_scenes, format_scene, load_scene, parse_override,
                       scene_from_dict, scene_path, scene_to_dict, validate)
from nld.model.scene_model import Body, Driver, Joint, Load, Scene


def raw_slider_crank() -> dict:
    return tomllib.loads(scene_path("slider_crank").read_text(encoding="utf-8"))


def write(tmp_path, text: str, name: str = "s.toml"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def toml_without(section_header: str) -> str:
    """The slider-crank file without one [table] (its header and key lines)."""
    out, skip = [], False
    for line in scene_path("slider_crank").read_text(encoding="utf-8").splitlines():
        if line.startswith("["):
            skip = line.strip() == section_header
        if not skip:
            out.append(line)
    return "\n".join(out) + "\n"


def assert_one_line(err: Exception, path: str, value: str) -> str:
    msg = str(err)
    assert "\n" not in msg, msg
    assert msg.startswith(path + " = "), msg
    assert value in msg, msg
    return msg


def scene_error(raw: dict, path: str, value: str) -> str:
    with pytest.raises(SceneError) as ei:
        scene_from_dict(raw)
    assert ei.value.path == path, str(ei.value)
    return assert_one_line(ei.value, path, value)


# ------------------------------------------------------------------------------------------ loading

def test_slider_crank_values():
    s = load_scene("slider_crank")
    assert s.name == "slider_crank"
    assert s.source.endswith("slider_crank.toml")
    assert s.gravity == (0.0, -9.81)
    assert list(s.bodies) == ["crank", "rod", "slider"]
    assert s.bodies["crank"].mass == 0.30
    assert s.bodies["rod"].inertia == 2.5e-4
    assert s.bodies["rod"].points == {"A": (-0.06, 0.0), "B": (0.06, 0.0)}
    assert s.ground_points["O"] == (0.0, 0.0)
    b = s.joints["B"]
    assert b.type == "revolute" and b.bodies == ("slider", "rod") and b.points == ("B", "B")
    assert b.clearance == 0.5e-3 and b.journal_radius == 9.5e-3 and b.has_clearance
    assert b.contact.law == "lankarani_nikravesh" and b.contact.stiffness is None
    assert b.contact.young == (207e9, 207e9) and b.contact.restitution == 0.9
    assert b.friction.law == "none" and b.friction.mu == 0.0
    assert [j.name for j in s.clearance_joints] == ["B"]
    assert s.joints["S"].type == "prismatic" and s.joints["S"].axis == (1.0, 0.0)
    assert not s.joints["O"].has_clearance
    assert s.driver.joint == "O" and s.driver.mode == "speed"
    assert s.driver.speed == pytest.approx(5000 * 2 * math.pi / 60)
    assert s.loads == []


def test_builtin_scenes_listed_with_descriptions():
    scenes = builtin_scenes()
    assert "slider_crank" in scenes
    for name, desc in scenes.items():
        assert isinstance(desc, str) and desc and "\n" not in desc
        assert scene_path(name).name == f"{name}.toml"


@pytest.mark.parametrize("name", sorted(builtin_scenes()))
def test_every_builtin_scene_validates_and_round_trips(name):
    s = load_scene(name)
    assert s.name == name
    assert scene_from_dict(scene_to_dict(s)) == s
    assert validate(s) == s
    listing = format_scene(s)
    assert f"scene.name = \"{name}\"" in listing
    for b in s.bodies:
        assert f"bodies.{b}.mass = " in listing and f"bodies.{b}.mass" in listing


def test_load_scene_from_path(tmp_path):
    p = write(tmp_path, scene_path("slider_crank").read_text(encoding="utf-8"), "copy.toml")
    s = load_scene(p)
    assert s.source == str(p) and s.joints["B"].clearance == 0.5e-3
    assert load_scene(str(p)) == s


def test_unknown_scene_lists_builtins(tmp_path):
    with pytest.raises(InputError, match="slider_crank"):
        scene_path("no_such_scene")
    with pytest.raises(InputError, match="slider_crank"):
        load_scene(tmp_path / "missing.toml")


def test_malformed_toml_reports_file_and_line(tmp_path):
    p = write(tmp_path, '[scene]\nname = "x"\n\n[bodies.a]\nmass = = 1\n')
    with pytest.raises(InputError) as ei:
        load_scene(p)
    msg = str(ei.value)
    assert "\n" not in msg
    assert "s.toml" in msg and "line 5" in msg
    # an error tomllib places at the end of the document still names a line
    p = write(tmp_path, '[scene]\nname = "x"\n[bodies.a]\nmass = [1,\n', "eof.toml")
    with pytest.raises(InputError) as ei:
        load_scene(p)
    assert "eof.toml" in str(ei.value) and "line 4" in str(ei.value)


# ------------------------------------------------------------------------------------------ overrides

def test_parse_override():
    assert parse_override("joints.B.clearance=0.5e-3") == ("joints.B.clearance", 0.0005)
    assert parse_override("driver.speed = 100") == ("driver.speed", 100)
    assert parse_override("joints.B.friction.law=coulomb") == ("joints.B.friction.law", "coulomb")
    assert parse_override('joints.B.friction.law="ambrosio"') == ("joints.B.friction.law", "ambrosio")
    assert parse_override("loads.0.value=[1.0, 0.0]") == ("loads.0.value", [1.0, 0.0])
    k, v = parse_override("bodies.rod.mass=nan")
    assert k == "bodies.rod.mass" and math.isnan(v)
    for bad in ("joints.B.clearance", "=1", "a..b=1", "x=[1.0,", 'x="open'):
        with pytest.raises(InputError) as ei:
            parse_override(bad)
        assert bad in str(ei.value) or repr(bad) in str(ei.value)


def test_override_round_trip():
    s = load_scene("slider_crank", ["joints.B.clearance=2e-4", "joints.B.friction.mu=0.05", "driver.speed=100"])
    d = scene_to_dict(s)
    assert d["joints"]["B"]["clearance"] == 2e-4
    assert d["joints"]["B"]["friction"]["mu"] == 0.05
    assert d["driver"]["speed"] == 100.0
    assert "joints.B.clearance = 0.0002 m" in format_scene(s)
    assert scene_from_dict(d) == s
    # the dict form gives the same scene
    s2 = load_scene("slider_crank", {"joints.B.clearance": 2e-4, "joints.B.friction.mu": 0.05,
                                     "driver.speed": 100})
    assert s2 == s
    # the base scene is unchanged by an override run
    assert load_scene("slider_crank").joints["B"].clearance == 0.5e-3


def test_override_creates_absent_subtable(tmp_path):
    p = write(tmp_path, toml_without("[joints.B.friction]"))
    assert "friction" not in tomllib.loads(p.read_text())["joints"]["B"]
    s = load_scene(p, ["joints.B.friction.mu=0.05", "joints.B.friction.law=coulomb"])
    assert s.joints["B"].friction.mu == 0.05 and s.joints["B"].friction.law == "coulomb"
    p = write(tmp_path, toml_without("[driver]"), "nodriver.toml")
    assert load_scene(p).driver is None
    s = load_scene(p, ["driver.joint=O", "driver.speed=10"])
    assert s.driver.joint == "O" and s.driver.speed == 10.0


def test_override_indices():
    raw = raw_slider_crank()
    raw["loads"] = [{"type": "force", "body": "slider", "point": "S", "value": [-10.0, 0.0]}]
    apply_overrides(raw, ["loads.0.value=[5.0, 1.0]", "scene.gravity.1=-1.5", "bodies.rod.points.B.0=0.07"])
    s = scene_from_dict(raw)
    assert s.loads[0].value == (5.0, 1.0)
    assert s.gravity == (0.0, -1.5)
    assert s.bodies["rod"].points["B"] == (0.07, 0.0)
    with pytest.raises(SceneError) as ei:
        apply_overrides(raw, ["loads.3.value=1"])
    assert_one_line(ei.value, "loads.3", "1")


@pytest.mark.parametrize("key, path, listed", [
    ("frobnicate=1", "frobnicate", "joints"),
    ("joints.B.clearence=1e-3", "joints.B.clearence", "clearance"),
    ("joints.B.friction.muu=0.1", "joints.B.friction.muu", "tangential_damping"),
    ("joints.Q.clearance=1e-3", "joints.Q", "B"),
    ("bodies.arm.mass=1", "bodies.arm", "crank"),
    ("driver.sped=1", "driver.sped", "speed"),
    ("loads.0.value=1", "loads.0", "no"),
])
def test_override_unknown_key(key, path, listed):
    with pytest.raises(SceneError) as ei:
        load_scene("slider_crank", [key])
    msg = assert_one_line(ei.value, path, repr(parse_override(key)[1]))
    assert listed in msg


# ------------------------------------------------------------------------------------------ errors

def test_negative_clearance():
    raw = raw_slider_crank()
    raw["joints"]["B"]["clearance"] = -0.001
    msg = scene_error(raw, "joints.B.clearance", "-0.001")
    assert msg == "joints.B.clearance = -0.001: must be >= 0 (m)"
    with pytest.raises(SceneError) as ei:
        load_scene("slider_crank", ["joints.B.clearance=-1e-3"])
    assert_one_line(ei.value, "joints.B.clearance", "-0.001")


def test_unknown_key_top_level_and_in_joint():
    raw = raw_slider_crank()
    raw["solver"] = {"rtol": 1e-6}
    msg = scene_error(raw, "solver", "rtol")
    assert "allowed" in msg and "bodies" in msg and "joints" in msg
    raw = raw_slider_crank()
    raw["joints"]["B"]["clearence"] = 1e-3
    msg = scene_error(raw, "joints.B.clearence", "0.001")
    assert "clearance" in msg and "journal_radius" in msg
    raw = raw_slider_crank()
    raw["joints"]["B"]["contact"]["lw"] = "hertz"
    assert "restitution" in scene_error(raw, "joints.B.contact.lw", "hertz")


def test_unknown_body_and_point_in_joint():
    raw = raw_slider_crank()
    raw["joints"]["A"]["bodies"] = ["crank", "conrod"]
    msg = scene_error(raw, "joints.A.bodies", "conrod")
    assert "rod" in msg and "ground" in msg
    raw = raw_slider_crank()
    raw["joints"]["A"]["points"] = ["A", "Z"]
    msg = scene_error(raw, "joints.A.points", "Z")
    assert "available: A, B" in msg
    raw = raw_slider_crank()
    raw["joints"]["A"]["bodies"] = ["rod", "rod"]
    scene_error(raw, "joints.A.bodies", "rod")


def test_nan_mass_from_override_and_from_toml(tmp_path):
    with pytest.raises(SceneError) as ei:
        load_scene("slider_crank", ["bodies.rod.mass=nan"])
    assert "finite" in assert_one_line(ei.value, "bodies.rod.mass", "nan")
    text = scene_path("slider_crank").read_text(encoding="utf-8").replace("mass = 0.21", "mass = nan")
    with pytest.raises(SceneError) as ei:
        load_scene(write(tmp_path, text))
    assert "finite" in assert_one_line(ei.value, "bodies.rod.mass", "nan")
    with pytest.raises(SceneError) as ei:
        load_scene("slider_crank", ["driver.speed=inf"])
    assert "finite" in assert_one_line(ei.value, "driver.speed", "inf")


def test_wrong_types():
    raw = raw_slider_crank()
    raw["bodies"]["crank"]["mass"] = "0.3"
    assert "number" in scene_error(raw, "bodies.crank.mass", "'0.3'")
    raw = raw_slider_crank()
    raw["bodies"]["crank"]["mass"] = True
    scene_error(raw, "bodies.crank.mass", "True")
    raw = raw_slider_crank()
    raw["scene"]["gravity"] = [0.0, -9.81, 0.0]
    scene_error(raw, "scene.gravity", "[0.0, -9.81, 0.0]")
    raw = raw_slider_crank()
    raw["joints"]["B"]["contact"]["law"] = "kelvin"
    assert "hunt_crossley" in scene_error(raw, "joints.B.contact.law", "kelvin")
    raw = raw_slider_crank()
    raw["joints"] = "none"
    scene_error(raw, "joints", "none")
    with pytest.raises(SceneError) as ei:
        load_scene("slider_crank", ["bodies.rod.inertia=heavy"])
    assert_one_line(ei.value, "bodies.rod.inertia", "heavy")


@pytest.mark.parametrize("path, value, snippet", [
    ("bodies.crank.mass", 0.0, "> 0"),
    ("bodies.crank.inertia", -1e-4, "> 0"),
    ("joints.B.journal_radius", 0.0, "clearance > 0"),
    ("joints.B.contact.restitution", 0.0, "(0, 1]"),
    ("joints.B.contact.restitution", 1.2, "(0, 1]"),
    ("joints.B.contact.exponent", 0.0, "> 0"),
    ("joints.B.contact.stiffness", -1.0, "> 0"),
    ("joints.B.contact.poisson", [0.3, 0.5], "[0, 0.5)"),
    ("joints.B.contact.young", [0.0, 2e11], "> 0"),
    ("joints.B.friction.mu", -0.1, ">= 0"),
    ("joints.B.friction.v1", 1e-5, "v0"),
    ("joints.B.friction.v0", -1e-5, ">= 0"),
    ("joints.S.axis", [0.0, 0.0], "non-zero"),
    ("joints.S.clearance", 1e-3, "prismatic"),
    ("driver.mode", "position", "torque"),
    ("driver.joint", "A", "ground"),
    ("driver.joint", "S", "revolute"),
    ("driver.joint", "X", "available"),
    ("scene.name", "Slider-Crank", "[a-z0-9_]+"),
])
def test_field_checks(path, value, snippet):
    raw = raw_slider_crank()
    with pytest.raises(SceneError) as ei:
        scene_from_dict(apply_overrides(raw, {path: value}))
    assert ei.value.path == path
    assert snippet in assert_one_line(ei.value, path, repr(value))


def test_driver_joint_with_clearance():
    raw = raw_slider_crank()
    raw["joints"]["O"].update(clearance=1e-4, journal_radius=5e-3)
    assert "clearance" in scene_error(raw, "driver.joint", "O")


def test_prismatic_axis_is_normalised():
    s = load_scene("slider_crank", ["joints.S.axis=[3.0, 4.0]"])
    assert s.joints["S"].axis == pytest.approx((0.6, 0.8))
    assert validate(s) == s


def test_disconnected_body():
    raw = raw_slider_crank()
    raw["bodies"]["flywheel"] = {"mass": 1.0, "inertia": 1e-3, "points": {"C": [0.0, 0.0]}}
    msg = scene_error(raw, "bodies.flywheel", "flywheel")
    assert "joint" in msg
    # joined only to another floating body: still not part of the mechanism
    raw["bodies"]["hub"] = {"mass": 1.0, "inertia": 1e-3, "points": {"C": [0.0, 0.0]}}
    raw["joints"]["F"] = {"type": "revolute", "bodies": ["flywheel", "hub"], "points": ["C", "C"]}
    assert "ground" in scene_error(raw, "bodies.flywheel", "flywheel")


def test_loads():
    raw = raw_slider_crank()
    raw["bodies"]["rod"]["points"]["P"] = [0.0, 0.01]
    raw["loads"] = [
        {"type": "force", "body": "slider", "point": "S", "value": [-10.0, 0.0]},
        {"type": "torque", "body": "crank", "value": 5, "modulation": "crank_halves"},
        {"type": "torque", "body": "rod", "value": 2.0, "modulation": "angle_threshold", "threshold": 1.5},
        {"type": "torque", "body": "crank", "value": 1.0, "modulation": "crank_table",
         "table_angles": [0.0, 3.14, 6.28], "table_values": [1.0, -1.0, 1.0]},
        {"type": "spring", "bodies": ["rod", "ground"], "points": ["P", "O"], "stiffness": 1e3,
         "free_length": 0.1},
    ]
    s = scene_from_dict(copy.deepcopy(raw))
    assert s.loads[0].value == (-10.0, 0.0)
    assert s.loads[1].value == 5.0 and isinstance(s.loads[1].value, float)
    assert s.loads[2].threshold == 1.5
    assert s.loads[3].table_angles == (0.0, 3.14, 6.28)
    assert s.loads[4].bodies == ("rod", "ground") and s.loads[4].damping == 0.0
    assert scene_from_dict(scene_to_dict(s)) == s
    assert "loads.0.value = [-10.0, 0.0] N" in format_scene(s)
    assert "loads.1.value = 5.0 N m" in format_scene(s)

    bad = [
        (0, "value", 10.0, "2-vector"),
        (0, "point", "Q", "available"),
        (0, "body", "piston", "available"),
        (1, "value", [1.0, 2.0], "number"),
        (1, "point", "A", "allowed"),
        (1, "modulation", "sine", "crank_table"),
        (3, "table_angles", [0.0, 3.0, 2.0], "increasing"),
        (3, "table_angles", [0.0, 7.0], "2 pi"),
        (3, "table_values", [1.0, 2.0], "as many"),
        (4, "stiffness", -1.0, ">= 0"),
        (4, "free_length", -0.1, ">= 0"),
        (4, "points", ["P", "G2"], "available"),
    ]
    for i, key, value, snippet in bad:
        r = copy.deepcopy(raw)
        r["loads"][i][key] = value
        with pytest.raises(SceneError) as ei:
            scene_from_dict(r)
        assert snippet in assert_one_line(ei.value, f"loads.{i}.{key}", repr(value)), (i, key)


def test_validate_python_built_scene():
    s = Scene(
        name="pendulum",
        ground_points={"O": (0.0, 0.0)},
        bodies={"bob": Body("bob", mass=1, inertia=0.01, points={"P": (-0.5, 0.0)})},
        joints={"O": Joint("O", "revolute", ("ground", "bob"), ("O", "P"))},
        driver=Driver("O", mode="torque", speed=1.0),
        loads=[Load("torque", body="bob", value=0.5)],
    )
    v = validate(s)
    assert v.bodies["bob"].mass == 1.0 and v.joints["O"].bodies == ("ground", "bob")
    assert validate(v) == v
    s.bodies["bob"].mass = -1.0
    with pytest.raises(SceneError) as ei:
        validate(s)
    assert_one_line(ei.value, "bodies.bob.mass", "-1.0")
    s.bodies["bob"].mass = 1.0
    s.joints["O"].clearance = 1e-4          # driver joint may not have clearance
    with pytest.raises(SceneError) as ei:
        validate(s)
    assert_one_line(ei.value, "joints.O.journal_radius", "0.0")
