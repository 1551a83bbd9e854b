"""Scene files: loading, overrides, validation and the resolved listing (docs/scene-format.md).

* :func:`load_scene` reads a built-in scene by name or a ``.toml`` file, applies ``--set`` style
  overrides to the raw table and validates it with :func:`scene_from_dict`.
* :func:`scene_from_dict` is the one place where scene input is checked: every problem is a
  :class:`~nld.errors.SceneError` whose one-line message names the dotted field path, the value
  and what is allowed, e.g. ``joints.B.clearance = -0.001: must be >= 0 (m)``.
* :func:`scene_to_dict` gives the fully resolved scene (defaults filled in) in the structure of the
  TOML file; ``scene_from_dict(scene_to_dict(s)) == s``. :func:`format_scene` lists it with units.
* :func:`validate` applies the same checks to a scene built in Python from the dataclasses.
"""
from __future__ import annotations

import math
import os
import numbers
import re
import tomllib
from importlib import resources
from pathlib import Path

from nld.errors import InputError, SceneError
from nld.laws.law import contact_laws
from nld.model.scene_model import (CONTROL_METHODS, DRIVER_MODES, FRICTION_LAWS, JOINT_TYPES, LOAD_TYPES,
                          MODULATIONS, Body, Contact, Controller, Driver, Friction, Joint, Load, Scene)

__all__ = ["builtin_scenes", "scene_path", "load_scene", "resolve_scene", "parse_override", "apply_overrides",
           "scene_value", "NO_VALUE",
           "scene_from_dict", "scene_to_dict", "format_scene", "validate",
           "Scene", "Body", "Joint", "Contact", "Friction", "Driver", "Load", "Controller"]

GROUND = "ground"
SCENE_NAME_RE = re.compile(r"[a-z0-9_]+")
ITEM_NAME_RE = re.compile(r"[A-Za-z0-9_]+")          # body, joint and point names (used in dotted paths)
OVERRIDE_KEY_RE = re.compile(r"[A-Za-z0-9_]+(\.[A-Za-z0-9_]+)*")
TWO_PI = 2.0 * math.pi

# ---------------------------------------------------------------------------------------------------
# allowed keys of every table (the schema), in the order scene_to_dict writes them

TOP_KEYS = ("scene", "ground", "bodies", "joints", "driver", "loads", "controller")
SCENE_KEYS = ("name", "description", "gravity", "source", "method", "rtol")
GROUND_KEYS = ("points",)
BODY_KEYS = ("mass", "inertia", "points", "angle0")
JOINT_KEYS = ("type", "bodies", "points", "clearance", "journal_radius", "axis", "contact", "friction")
CONTACT_KEYS = ("law", "stiffness", "young", "poisson", "exponent", "restitution", "damping",
                "min_approach_velocity")
FRICTION_KEYS = ("law", "mu", "v0", "v1", "tangential_damping", "mu_s")
DRIVER_KEYS = ("joint", "mode", "speed", "angle0", "inertia", "torque", "torque_slope")
CONTROLLER_KEYS = ("body", "signal", "method", "gain", "delay", "memory", "offset", "u_max")
MODULATION_KEYS = ("modulation", "threshold", "table_angles", "table_values")
LOAD_KEYS_BY_TYPE = {
    "force": ("type", "body", "point", "value") + MODULATION_KEYS,
    "torque": ("type", "body", "value") + MODULATION_KEYS,
    "spring": ("type", "bodies", "points", "stiffness", "free_length", "damping") + MODULATION_KEYS,
}
LOAD_KEYS = tuple(dict.fromkeys(k for ks in LOAD_KEYS_BY_TYPE.values() for k in ks))


class _Leaf:
    """A value (number, string, vector)."""


class _Table:
    """A table with a fixed set of keys; absent sub-tables are created by overrides."""

    def __init__(self, keys: dict[str, object]):
        self.keys = keys


class _Named:
    """A table keyed by names from the file (bodies, joints, points): only existing names."""

    def __init__(self, child, what: str):
        self.child = child
        self.what = what


class _Array:
    """An array of tables indexed 0, 1, ... (loads): only existing indices."""

    def __init__(self, child, what: str):
        self.child = child
        self.what = what


_LEAF = _Leaf()


def _table(keys, **sub) -> _Table:
    return _Table({k: sub.get(k, _LEAF) for k in keys})


_SCHEMA = _table(
    TOP_KEYS,
    scene=_table(SCENE_KEYS),
    ground=_table(GROUND_KEYS, points=_Named(_LEAF, "ground point")),
    bodies=_Named(_table(BODY_KEYS, points=_Named(_LEAF, "point")), "body"),
    joints=_Named(_table(JOINT_KEYS, contact=_table(CONTACT_KEYS), friction=_table(FRICTION_KEYS)), "joint"),
    driver=_table(DRIVER_KEYS),
    loads=_Array(_table(LOAD_KEYS), "load"),
    controller=_table(CONTROLLER_KEYS),
)

# ---------------------------------------------------------------------------------------------------
# built-in scenes and files


def _scenes_dir():
    return resources.files("nld").joinpath("scenes")


def _builtin_files() -> dict[str, object]:
    try:
        entries = list(_scenes_dir().iterdir())
    except (FileNotFoundError, NotADirectoryError):   # pragma: no cover - broken install
        return {}
    out = {}
    for t in sorted(entries, key=lambda t: t.name):
        if t.name.endswith(".toml") and t.is_file():
            out[t.name[:-len(".toml")]] = t
    return out


def builtin_scenes() -> dict[str, str]:
    """Name -> one-line description of every built-in scene (``nld/scenes/*.toml``)."""
    out = {}
    for name, t in _builtin_files().items():
        try:
            raw = tomllib.loads(t.read_text(encoding="utf-8"))
            desc = raw.get("scene", {}).get("description", "")
            desc = str(desc).strip().splitlines()[0] if str(desc).strip() else ""
        except (tomllib.TOMLDecodeError, OSError, AttributeError, UnicodeDecodeError) as e:
            desc = f"(unreadable: {_one_line(str(e))})"
        out[name] = desc
    return out


def _builtin_list() -> str:
    names = list(_builtin_files())
    return ", ".join(names) if names else "(none)"


def scene_path(name_or_path) -> Path:
    """Path of a built-in scene given by name, or of a ``.toml`` file given by path."""
    builtins = _builtin_files()
    text = str(name_or_path)
    if not isinstance(name_or_path, Path) and text in builtins:
        t = builtins[text]
        if isinstance(t, Path):
            return t
        # a resource not on the file system (zip import): extract it for the lifetime of the process
        cm = resources.as_file(t)
        p = cm.__enter__()
        _KEEP_ALIVE.append(cm)
        return Path(p)
    if not isinstance(name_or_path, (str, os.PathLike)):
        from nld.errors import InputTypeError
        raise InputTypeError(f"scene = {name_or_path!r}: must be a built-in scene name or the path of "
                             f"a .toml file (built-in scenes: {_builtin_list()})")
    p = Path(name_or_path).expanduser()
    if p.is_file():
        return p
    if p.is_dir():
        raise InputError(f"scene file {text}: is a directory, not a .toml file (built-in scenes: "
                         f"{_builtin_list()})")
    if isinstance(name_or_path, Path) or p.suffix or "/" in text or "\\" in text:
        raise InputError(f"scene file not found: {text} (built-in scenes: {_builtin_list()})")
    raise InputError(f"unknown scene {text!r}: not a built-in scene ({_builtin_list()}) nor a .toml file")


_KEEP_ALIVE: list = []


def _one_line(s: str) -> str:
    return " ".join(s.split())


def load_scene(name_or_path, overrides: dict[str, object] | list[str] | None = None) -> Scene:
    """Read a scene (built-in name or ``.toml`` path), apply overrides to the raw table, validate.

    overrides: ``{"joints.B.clearance": 2e-4}`` or ``["joints.B.clearance=2e-4", ...]`` (parsed with
    :func:`parse_override`). Malformed TOML or an unreadable file -> InputError; any bad field or
    override key -> SceneError.
    """
    path = scene_path(name_or_path)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise InputError(f"cannot read scene file {path}: {_one_line(e.strerror or str(e))}") from None
    try:
        text = data.decode("utf-8")
        raw = tomllib.loads(text)
    except UnicodeDecodeError as e:
        raise InputError(f"{path}: not UTF-8 text ({_one_line(str(e))})") from None
    except tomllib.TOMLDecodeError as e:
        msg = _one_line(str(e))
        if "line " not in msg:      # "(at end of document)": name the last line
            last = max(1, len(text.splitlines()))
            msg = msg.replace("at end of document", f"at line {last}, end of document")
        raise InputError(f"{path}: malformed TOML: {msg}") from None
    if overrides:
        apply_overrides(raw, overrides)
    return scene_from_dict(raw, source=str(path))


def resolve_scene(scene, overrides=None) -> Scene:
    """A Scene from a Scene, a built-in scene name or a TOML path, with ``overrides`` (as for
    ``nld --set``) applied; a Scene given without overrides is returned as it is."""
    if isinstance(scene, Scene):
        if not overrides:
            return scene
        raw = scene_to_dict(scene)
        apply_overrides(raw, overrides)
        return scene_from_dict(raw, scene.source)
    return load_scene(scene, overrides)


# ---------------------------------------------------------------------------------------------------
# overrides


def parse_override(text: str) -> tuple[str, object]:
    """``"joints.B.clearance=0.5e-3"`` -> ``("joints.B.clearance", 0.0005)``.

    The value is parsed as a TOML value (``1e-3``, ``"coulomb"``, ``[1.0, 0.0]``, ``nan``); text that
    is not TOML is taken as a bare string (``friction.law=coulomb``), except text that starts like a
    TOML string, array or inline table, which must then be valid.
    """
    if not isinstance(text, str) or "=" not in text:
        raise InputError(f"bad override {text!r}: expected KEY=VALUE, e.g. joints.B.clearance=0.5e-3")
    key, _, vtext = text.partition("=")
    key, vtext = key.strip(), vtext.strip()
    if not OVERRIDE_KEY_RE.fullmatch(key):
        raise InputError(f"bad override {text!r}: the key must be a dotted path such as joints.B.clearance")
    if "\n" in vtext or "\r" in vtext:
        raise InputError(f"bad override {text!r}: the value must be on one line")
    try:
        parsed = tomllib.loads("v = " + vtext)
    except tomllib.TOMLDecodeError as e:
        if vtext[:1] in "[{\"'":
            msg = _one_line(str(e)).replace("at line 1, ", "at ")
            raise InputError(f"bad override {text!r}: the value is not valid TOML ({msg})") from None
        return key, vtext
    if list(parsed) != ["v"]:
        raise InputError(f"bad override {text!r}: the value must be one TOML value")
    return key, parsed["v"]


def _is_index(part: str) -> bool:
    return part.isdigit()


NO_VALUE = object()     # scene_value's answer for a key the scene does not have


def scene_value(scene, key: str, default=NO_VALUE):
    """The value at the dotted scene key ``key`` (``joints.B.clearance``, ``loads.0.value``: the
    keys ``apply_overrides`` sets) of a Scene or of its raw table (``scene_to_dict``); ``default``
    (:data:`NO_VALUE` unless given) where the scene has no such key. The one reader of a scene
    key: ``SceneSystem.parameter``, the sweeps and the chaos maps address a scene parameter by it."""
    node = scene if isinstance(scene, dict) else scene_to_dict(scene)
    for part in str(key).split("."):
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and _is_index(part) and int(part) < len(node):
            node = node[int(part)]
        else:
            return default
    return node


def apply_overrides(raw: dict, overrides) -> dict:
    """Set dotted keys in the raw scene table (in place; also returned).

    ``overrides`` is a mapping key -> value or a list of ``KEY=VALUE`` strings. Keys follow the file
    structure (``joints.B.friction.mu``, ``driver.speed``, ``loads.0.value``, ``scene.gravity.1``).
    A key the schema does not allow, or a body/joint/point name or load index that does not exist,
    -> SceneError naming the path and listing what is allowed. A sub-table the schema allows but the
    file lacks (``[joints.B.friction]``, ``[driver]``) is created.
    """
    if overrides is None:
        return raw
    if isinstance(overrides, str):
        overrides = [overrides]
    from nld.errors import InputTypeError
    if isinstance(overrides, dict):
        items = list(overrides.items())
    elif isinstance(overrides, (list, tuple)):
        items = []
        for o in overrides:
            if isinstance(o, str):
                items.append(parse_override(o))
            elif isinstance(o, (list, tuple)) and len(o) == 2:
                items.append(tuple(o))
            else:
                raise InputTypeError(f"overrides: item {o!r} is not a 'KEY=VALUE' string or a "
                                     "(key, value) pair")
    else:
        raise InputTypeError(f"overrides = {overrides!r}: must be a dict key -> value or a list of "
                             "'KEY=VALUE' strings")
    for key, value in items:
        _apply_one(raw, str(key), value)
    return raw


def _apply_one(raw: dict, key: str, value) -> None:
    parts = key.split(".")
    if not key or any(p == "" for p in parts):
        raise SceneError(key, value, "not a dotted key such as joints.B.clearance")
    cur, schema, path = raw, _SCHEMA, ""
    for i, part in enumerate(parts):
        last = i == len(parts) - 1
        here = f"{path}.{part}" if path else part
        if isinstance(schema, _Table):
            if not isinstance(cur, dict):
                raise SceneError(path, cur, "must be a table")
            if part not in schema.keys:
                where = f"in {path}" if path else "at the top level"
                raise SceneError(here, value, f"unknown key {part!r} {where}; allowed: {', '.join(schema.keys)}")
            child = schema.keys[part]
            if last:
                cur[part] = value
                return
            if part not in cur:
                if isinstance(child, _Table):
                    cur[part] = {}
                else:
                    what = {"bodies": "no bodies", "joints": "no joints", "loads": "no loads",
                            "points": "no points"}.get(part, "no such entry")
                    raise SceneError(f"{here}.{parts[i + 1]}", value, f"the scene has {what} ([{here}] is absent)")
            cur, schema, path = cur[part], child, here
        elif isinstance(schema, _Named):
            if not isinstance(cur, dict):
                raise SceneError(path, cur, "must be a table")
            if part not in cur:
                avail = ", ".join(map(str, cur)) or "(none)"
                raise SceneError(here, value, f"no {schema.what} named {part!r}; available: {avail}")
            if last:
                cur[part] = value
                return
            cur, schema, path = cur[part], schema.child, here
        elif isinstance(schema, _Array):
            if not isinstance(cur, list):
                raise SceneError(path, cur, "must be an array of tables")
            if not _is_index(part) or int(part) >= len(cur):
                rng = f"0..{len(cur) - 1}" if cur else "none: the scene has no entries"
                raise SceneError(here, value, f"{path} is indexed by number; valid indices: {rng}")
            idx = int(part)
            if last:
                cur[idx] = value
                return
            cur, schema, path = cur[idx], schema.child, here
        else:   # a leaf value: only an existing array can be indexed further
            if not isinstance(cur, list):
                raise SceneError(here, value, f"{path} is a value, not a table")
            if not _is_index(part) or int(part) >= len(cur):
                raise SceneError(here, value, f"{path} has {len(cur)} elements; valid indices: "
                                              f"{'0..' + str(len(cur) - 1) if cur else 'none'}")
            idx = int(part)
            if last:
                cur[idx] = value
                return
            cur, path = cur[idx], here


# ---------------------------------------------------------------------------------------------------
# validation helpers


class _Missing:
    def __repr__(self):
        return "<missing>"


_MISSING = _Missing()


def _unit(unit: str | None) -> str:
    return f" ({unit})" if unit else ""


def _check_keys(tbl, path: str, allowed, what: str = "") -> None:
    if not isinstance(tbl, dict):
        raise SceneError(path or "<scene>", tbl, "must be a table")
    for k, v in tbl.items():
        if k not in allowed:
            where = what or (f"in {path}" if path else "at the top level")
            p = f"{path}.{k}" if path else str(k)
            raise SceneError(p, v, f"unknown key {k!r} {where}; allowed: {', '.join(allowed)}")


def _table_of(tbl: dict, key: str, path: str, required: bool = False) -> dict:
    v = tbl.get(key, _MISSING)
    if v is _MISSING:
        if required:
            raise SceneError(path, _MISSING, "required table")
        return {}
    if not isinstance(v, dict):
        raise SceneError(path, v, "must be a table")
    return v


def _get(tbl: dict, key: str, path: str, default=_MISSING, hint: str = ""):
    if key in tbl:
        return tbl[key]
    if default is _MISSING:
        raise SceneError(path, _MISSING, "required" + (f": {hint}" if hint else ""))
    return default


def _number(v, path: str, unit: str | None = None) -> float:
    if isinstance(v, bool) or not isinstance(v, numbers.Real):
        raise SceneError(path, v, f"must be a number{_unit(unit)}")
    try:
        x = float(v)
    except (OverflowError, ValueError):
        raise SceneError(path, v, f"must be a finite number{_unit(unit)}") from None
    if not math.isfinite(x):
        raise SceneError(path, v, f"must be a finite number{_unit(unit)}")
    return x


# Physically absurd values that are valid numbers (a 1e300 kg crank) are refused with the plausible
# range, not warned about: they overflow the equations (inf/NaN states) or make the integrator
# crawl, and a run with them is never what was meant. The ranges span MEMS linkages to
# heavy machinery (docs/scene-format.md, "Plausible ranges").
PLAUSIBLE = {
    "mass": (1e-9, 1e7),            # kg
    "inertia": (1e-18, 1e9),        # kg m^2
    "speed": (0.0, 1e5),            # |rad/s| (about 955 000 rpm)
    "length": (0.0, 1e3),           # |m|: point coordinates, journal radii
    "friction": (0.0, 5.0),         # friction coefficients mu, mu_s (-): rubber on dry surfaces ~ 1-3
}


def _plausible(x: float, v, p: str, what: str, unit: str | None) -> None:
    lo, hi = PLAUSIBLE[what]
    a = abs(x)
    if a > hi or (x != 0.0 and a < lo):
        rng = f"{lo:g} .. {hi:g}" if lo > 0 else f"|value| <= {hi:g}"
        raise SceneError(p, v, f"outside the plausible range {rng}{_unit(unit)} of a mechanism "
                               "(docs/scene-format.md, 'Plausible ranges')")


def _num(tbl, key, path, unit=None, default=_MISSING, *, gt=None, ge=None, lt=None, le=None,
         plausible: str | None = None) -> float:
    p = f"{path}.{key}"
    v = _get(tbl, key, p, default, hint=f"a number{_unit(unit)}")
    x = _number(v, p, unit)
    if gt is not None and not x > gt:
        raise SceneError(p, v, f"must be > {gt:g}{_unit(unit)}")
    if ge is not None and not x >= ge:
        raise SceneError(p, v, f"must be >= {ge:g}{_unit(unit)}")
    if lt is not None and not x < lt:
        raise SceneError(p, v, f"must be < {lt:g}{_unit(unit)}")
    if le is not None and not x <= le:
        raise SceneError(p, v, f"must be <= {le:g}{_unit(unit)}")
    if plausible is not None:
        _plausible(x, v, p, plausible, unit)
    return x


def _vec2(v, path: str, unit: str | None = None) -> tuple[float, float]:
    if not isinstance(v, (list, tuple)) or len(v) != 2:
        raise SceneError(path, v, f"must be a 2-vector [x, y] of numbers{_unit(unit)}")
    out = []
    for x in v:
        if isinstance(x, bool) or not isinstance(x, numbers.Real):
            raise SceneError(path, v, f"must be a 2-vector [x, y] of numbers{_unit(unit)}")
        try:
            fx = float(x)
        except (OverflowError, ValueError):
            fx = math.inf
        if not math.isfinite(fx):
            raise SceneError(path, v, f"must be a 2-vector of finite numbers{_unit(unit)}")
        out.append(fx)
    return (out[0], out[1])


def _numbers(v, path: str, unit: str | None = None) -> tuple[float, ...]:
    if not isinstance(v, (list, tuple)):
        raise SceneError(path, v, f"must be an array of numbers{_unit(unit)}")
    out = []
    for x in v:
        if isinstance(x, bool) or not isinstance(x, numbers.Real):
            raise SceneError(path, v, f"must be an array of numbers{_unit(unit)}")
        try:
            fx = float(x)
        except (OverflowError, ValueError):
            fx = math.inf
        if not math.isfinite(fx):
            raise SceneError(path, v, f"must be an array of finite numbers{_unit(unit)}")
        out.append(fx)
    return tuple(out)


def _string(v, path: str, what: str = "a string") -> str:
    if not isinstance(v, str):
        raise SceneError(path, v, f"must be {what}")
    return v


def _choice(tbl, key, path, allowed, default=_MISSING) -> str:
    p = f"{path}.{key}"
    v = _get(tbl, key, p, default, hint="one of " + ", ".join(allowed))
    if not isinstance(v, str) or v not in allowed:
        raise SceneError(p, v, "must be one of: " + ", ".join(allowed))
    return v


def _pair_of_names(tbl, key, path, what) -> tuple[str, str]:
    p = f"{path}.{key}"
    v = _get(tbl, key, p, hint=f"a pair [{what}, {what}]")
    if (not isinstance(v, (list, tuple)) or len(v) != 2 or not all(isinstance(s, str) for s in v)):
        raise SceneError(p, v, f"must be a pair of {what}s [\"a\", \"b\"]")
    return (v[0], v[1])


def _item_name(name, path: str, what: str) -> str:
    if not isinstance(name, str) or not ITEM_NAME_RE.fullmatch(name):
        raise SceneError(path, name, f"{what} names may contain only letters, digits and _")
    return name


def _points(v, path: str) -> dict[str, tuple[float, float]]:
    if not isinstance(v, dict):
        raise SceneError(path, v, "must be a table of name = [x, y] (m)")
    out = {}
    for name, xy in v.items():
        _item_name(name, f"{path}.{name}", "point")
        out[name] = _vec2(xy, f"{path}.{name}", "m")
        if max(abs(c) for c in out[name]) > PLAUSIBLE["length"][1]:
            raise SceneError(f"{path}.{name}", xy, f"outside the plausible range |x|, |y| <= "
                             f"{PLAUSIBLE['length'][1]:g} (m) of a mechanism (docs/scene-format.md, "
                             "'Plausible ranges')")
    return out


# ---------------------------------------------------------------------------------------------------
# scene_from_dict


def scene_from_dict(raw: dict, source: str = "") -> Scene:
    """Validate a raw scene table (the structure of the TOML file) and build the Scene."""
    _check_keys(raw, "", TOP_KEYS)

    # [scene]
    st = _table_of(raw, "scene", "scene", required=True)
    _check_keys(st, "scene", SCENE_KEYS)
    name = _get(st, "name", "scene.name", hint="an identifier matching [a-z0-9_]+")
    if not isinstance(name, str) or not SCENE_NAME_RE.fullmatch(name):
        raise SceneError("scene.name", name, "must match [a-z0-9_]+")
    description = _string(st.get("description", ""), "scene.description")
    gravity = _vec2(st.get("gravity", [0.0, 0.0]), "scene.gravity", "m/s^2")
    src = _string(st.get("source", ""), "scene.source")
    if source:
        src = str(source)
    from nld.integrators import METHODS
    from nld.settings import RTOL_RANGE_TEXT, rtol_in_range
    method = _choice(st, "method", "scene", METHODS, "dopri5") if "method" in st else ""
    rtol = _num(st, "rtol", "scene", None) if "rtol" in st else None
    if rtol is not None and not rtol_in_range(rtol):
        raise SceneError("scene.rtol", st["rtol"], f"must be {RTOL_RANGE_TEXT}")

    # [ground]
    gt = _table_of(raw, "ground", "ground")
    _check_keys(gt, "ground", GROUND_KEYS)
    ground_points = _points(gt.get("points", {}), "ground.points")

    # [bodies.*]
    bt = _table_of(raw, "bodies", "bodies")
    bodies: dict[str, Body] = {}
    for bname, b in bt.items():
        path = f"bodies.{bname}"
        _item_name(bname, path, "body")
        if bname == GROUND:
            raise SceneError(path, b, "'ground' is the fixed frame (give its points in [ground]), not a body")
        _check_keys(b, path, BODY_KEYS)
        bodies[bname] = Body(
            name=bname,
            mass=_num(b, "mass", path, "kg", gt=0, plausible="mass"),
            inertia=_num(b, "inertia", path, "kg m^2", gt=0, plausible="inertia"),
            points=_points(b.get("points", {}), f"{path}.points"),
            angle0=_num(b, "angle0", path, "rad", 0.0),
        )

    def points_of(body: str) -> dict:
        return ground_points if body == GROUND else bodies[body].points

    # [joints.*]
    jt = _table_of(raw, "joints", "joints")
    joints: dict[str, Joint] = {}
    for jname, j in jt.items():
        path = f"joints.{jname}"
        _item_name(jname, path, "joint")
        _check_keys(j, path, JOINT_KEYS)
        jtype = _choice(j, "type", path, JOINT_TYPES)
        jb = _pair_of_names(j, "bodies", path, "body name")
        for k, bn in enumerate(jb):
            if bn != GROUND and bn not in bodies:
                raise SceneError(f"{path}.bodies", list(jb), f"no body named {bn!r}; available: "
                                 + ", ".join([GROUND, *bodies]))
        if jb[0] == jb[1]:
            raise SceneError(f"{path}.bodies", list(jb), "a joint must join two different bodies")
        jp = _pair_of_names(j, "points", path, "point name")
        for k in range(2):
            pts = points_of(jb[k])
            if jp[k] not in pts:
                owner = "[ground]" if jb[k] == GROUND else f"body {jb[k]!r}"
                raise SceneError(f"{path}.points", list(jp), f"no point {jp[k]!r} on {owner}; available: "
                                 + (", ".join(pts) or "(none)"))
        clearance = _num(j, "clearance", path, "m", 0.0, ge=0)
        if jtype == "prismatic" and clearance > 0:
            raise SceneError(f"{path}.clearance", j["clearance"],
                             "must be 0 for a prismatic joint (clearance joints are revolute) (m)")
        journal_radius = _num(j, "journal_radius", path, "m", 0.0, ge=0, plausible="length")
        if clearance > 0 and not journal_radius > 0:
            raise SceneError(f"{path}.journal_radius", j.get("journal_radius", _MISSING),
                             "must be > 0 when clearance > 0 (m)")
        if clearance > 0 and not clearance < journal_radius:
            raise SceneError(f"{path}.clearance", j["clearance"],
                             f"must be < journal_radius = {journal_radius:g} m (the radial clearance "
                             "is the bearing radius minus the journal radius, a fraction of it) (m)")
        axis = _vec2(j.get("axis", [1.0, 0.0]), f"{path}.axis")
        n = math.hypot(*axis)
        if not n > 0:
            raise SceneError(f"{path}.axis", j.get("axis"), "must be a non-zero 2-vector")
        if abs(n - 1.0) > 1e-12:
            axis = (axis[0] / n, axis[1] / n)
        joints[jname] = Joint(
            name=jname, type=jtype, bodies=jb, points=jp, clearance=clearance,
            journal_radius=journal_radius, axis=axis,
            contact=_contact(_table_of(j, "contact", f"{path}.contact"), f"{path}.contact"),
            friction=_friction(_table_of(j, "friction", f"{path}.friction"), f"{path}.friction"),
        )

    # [driver]
    driver = None
    if "driver" in raw:
        dt = _table_of(raw, "driver", "driver")
        _check_keys(dt, "driver", DRIVER_KEYS)
        djoint = _get(dt, "joint", "driver.joint", hint="the name of a revolute joint with the ground")
        if not isinstance(djoint, str) or djoint not in joints:
            raise SceneError("driver.joint", djoint, "no joint of that name; available: "
                             + (", ".join(joints) or "(none)"))
        jj = joints[djoint]
        if jj.type != "revolute":
            raise SceneError("driver.joint", djoint, f"must be a revolute joint (joints.{djoint} is {jj.type})")
        if GROUND not in jj.bodies:
            raise SceneError("driver.joint", djoint, f"must join a body to the ground (joints.{djoint} joins "
                             f"{jj.bodies[0]} and {jj.bodies[1]})")
        if jj.clearance != 0.0:
            raise SceneError("driver.joint", djoint, f"must have zero clearance (joints.{djoint}.clearance = "
                             f"{jj.clearance!r})")
        driver = Driver(
            joint=djoint,
            mode=_choice(dt, "mode", "driver", DRIVER_MODES, "speed"),
            speed=_num(dt, "speed", "driver", "rad/s", 0.0, plausible="speed"),
            angle0=_num(dt, "angle0", "driver", "rad", 0.0),
            inertia=_num(dt, "inertia", "driver", "kg m^2", 0.0, ge=0, plausible="inertia"),
            torque=_num(dt, "torque", "driver", "N m", 0.0),
            torque_slope=_num(dt, "torque_slope", "driver", "N m s/rad", 0.0),
        )

    # [[loads]]
    lt = raw.get("loads", [])
    if not isinstance(lt, list):
        raise SceneError("loads", lt, "must be an array of tables [[loads]]")
    loads = [_load(ld, f"loads.{i}", bodies, points_of, driver) for i, ld in enumerate(lt)]

    # [controller]: a torque load on its body, appended after the file's loads
    controller = None
    if "controller" in raw:
        controller = _controller(_table_of(raw, "controller", "controller"), bodies, len(loads))
        loads.append(Load(type="torque", body=controller.body, value=controller.offset))

    _check_connected(bodies, joints)

    return Scene(name=name, description=description, gravity=gravity, ground_points=ground_points,
                 bodies=bodies, joints=joints, driver=driver, loads=loads, source=src,
                 method=method, rtol=rtol, controller=controller)


def _controller(c: dict, bodies: dict, index: int) -> Controller:
    """[controller] (docs/scene-format.md): checked here except ``signal``, a state name that
    only the compiled kernel knows (``nld control`` checks it)."""
    path = "controller"
    _check_keys(c, path, CONTROLLER_KEYS)
    body = _get(c, "body", f"{path}.body", hint="the name of the body the torque acts on")
    if not isinstance(body, str) or body not in bodies:
        raise SceneError(f"{path}.body", body, "no body of that name; available: "
                         + (", ".join(bodies) or "(none)"))
    signal = _string(c.get("signal", ""), f"{path}.signal", "a state name such as \"rod.phi_dot\"")
    delay = None
    if c.get("delay") is not None:
        delay = _num(c, "delay", path, "s", gt=0)
    memory = _num(c, "memory", path, "-", 0.0)
    if not 0.0 <= memory < 1.0:
        raise SceneError(f"{path}.memory", c["memory"], "R must be in [0, 1) (0: Pyragas; EDFC "
                         "weights period k by R^(k-1)) (-)")
    u_max = None
    if c.get("u_max") is not None:
        u_max = _num(c, "u_max", path, "N m", gt=0)
    method = _choice(c, "method", path, CONTROL_METHODS, "pyragas")
    if method == "pyragas" and memory != 0.0:
        raise SceneError(f"{path}.memory", c["memory"], "Pyragas control has R = 0; set "
                         f"{path}.method = \"edfc\" for R > 0 (-)")
    return Controller(body=body, signal=signal, method=method,
                      gain=_num(c, "gain", path, "N m per unit of the signal", 0.0),
                      delay=delay, memory=memory, offset=_num(c, "offset", path, "N m", 0.0),
                      u_max=u_max, load=index)


def _contact(c: dict, path: str) -> Contact:
    _check_keys(c, path, CONTACT_KEYS)
    d = Contact()
    stiffness = None
    if "stiffness" in c:
        stiffness = _num(c, "stiffness", path, "N/m^exponent", gt=0)
    young = _vec2(c.get("young", list(d.young)), f"{path}.young", "Pa")
    poisson = _vec2(c.get("poisson", list(d.poisson)), f"{path}.poisson")
    if stiffness is None:
        for k in range(2):
            if not young[k] > 0:
                raise SceneError(f"{path}.young", c.get("young"),
                                 "both moduli must be > 0 (Pa) [journal, bearing] (or give stiffness)")
            if not 0.0 <= poisson[k] < 0.5:
                raise SceneError(f"{path}.poisson", c.get("poisson"),
                                 "both ratios must be in [0, 0.5) [journal, bearing] (or give stiffness)")
    restitution = _num(c, "restitution", path, None, d.restitution)
    if not 0.0 < restitution <= 1.0:
        raise SceneError(f"{path}.restitution", c.get("restitution"), "must be in (0, 1]")
    return Contact(
        law=_choice(c, "law", path, contact_laws(), d.law),
        stiffness=stiffness, young=young, poisson=poisson,
        exponent=_num(c, "exponent", path, None, d.exponent, gt=0),
        restitution=restitution,
        damping=_num(c, "damping", path, "N s/m", d.damping, ge=0),
        min_approach_velocity=_num(c, "min_approach_velocity", path, "m/s", d.min_approach_velocity, gt=0),
    )


def _friction(f: dict, path: str) -> Friction:
    _check_keys(f, path, FRICTION_KEYS)
    d = Friction()
    v0 = _num(f, "v0", path, "m/s", d.v0, ge=0)
    v1 = _num(f, "v1", path, "m/s", d.v1)
    if not v1 > v0:
        raise SceneError(f"{path}.v1", f.get("v1", d.v1), f"must be > v0 = {v0!r} (m/s)")
    mu = _num(f, "mu", path, "-", d.mu, ge=0, plausible="friction")
    law = _choice(f, "law", path, FRICTION_LAWS, d.law)
    mu_s = None
    if f.get("mu_s") is not None:     # static coefficient of the coulomb law's stick mode (>= mu)
        mu_s = _num(f, "mu_s", path, "-", ge=0, plausible="friction")
        if law != "coulomb" and mu_s != mu:      # it would be ignored (mu_s = mu: what the law does)
            raise SceneError(f"{path}.mu_s", f["mu_s"], f"applies only to law = 'coulomb' (the static "
                             f"coefficient of its stick mode), and {path}.law = {law!r}: remove mu_s "
                             f"or set {path}.law = 'coulomb'")
        if not mu_s >= mu:
            raise SceneError(f"{path}.mu_s", f["mu_s"], f"must be >= mu = {mu!r} (static >= kinetic "
                             "friction coefficient, -)")
    return Friction(
        law=law,
        mu=mu,
        v0=v0, v1=v1,
        tangential_damping=_num(f, "tangential_damping", path, "N s/m", d.tangential_damping, ge=0),
        mu_s=mu_s,
    )


def _load(ld, path: str, bodies: dict, points_of, driver) -> Load:
    if not isinstance(ld, dict):
        raise SceneError(path, ld, "must be a table [[loads]]")
    ltype = _choice(ld, "type", path, LOAD_TYPES)
    _check_keys(ld, path, LOAD_KEYS_BY_TYPE[ltype], what=f"of a {ltype} load")

    def body_ref(v, p):
        if not isinstance(v, str) or v not in bodies:
            raise SceneError(p, v, "no body of that name; available: " + (", ".join(bodies) or "(none)"))
        return v

    out = Load(type=ltype)
    if ltype in ("force", "torque"):
        out.body = body_ref(_get(ld, "body", f"{path}.body", hint="a body name"), f"{path}.body")
        if ltype == "force":
            point = _get(ld, "point", f"{path}.point", hint="a point name of the body")
            if not isinstance(point, str) or point not in bodies[out.body].points:
                raise SceneError(f"{path}.point", point, f"no point of that name on body {out.body!r}; "
                                 "available: " + (", ".join(bodies[out.body].points) or "(none)"))
            out.point = point
            out.value = _vec2(_get(ld, "value", f"{path}.value", hint="[fx, fy] (N)"), f"{path}.value",
                              "N, global frame")
        else:
            out.value = _num(ld, "value", path, "N m")
    else:   # spring
        sb = _pair_of_names(ld, "bodies", path, "body name")
        for bn in sb:
            if bn != GROUND and bn not in bodies:
                raise SceneError(f"{path}.bodies", list(sb), f"no body named {bn!r}; available: "
                                 + ", ".join([GROUND, *bodies]))
        if sb[0] == sb[1]:
            raise SceneError(f"{path}.bodies", list(sb), "a spring must join two different bodies")
        sp = _pair_of_names(ld, "points", path, "point name")
        for k in range(2):
            pts = points_of(sb[k])
            if sp[k] not in pts:
                owner = "[ground]" if sb[k] == GROUND else f"body {sb[k]!r}"
                raise SceneError(f"{path}.points", list(sp), f"no point {sp[k]!r} on {owner}; available: "
                                 + (", ".join(pts) or "(none)"))
        out.bodies, out.points = sb, sp
        out.stiffness = _num(ld, "stiffness", path, "N/m", ge=0)
        out.free_length = _num(ld, "free_length", path, "m", 0.0, ge=0)
        out.damping = _num(ld, "damping", path, "N s/m", 0.0, ge=0)

    out.modulation = _choice(ld, "modulation", path, MODULATIONS, "constant")
    if ltype == "spring" and out.modulation != "constant":
        raise SceneError(f"{path}.modulation", out.modulation, "a spring load must be constant")
    if out.modulation in ("crank_halves", "crank_table") and driver is None:
        raise SceneError(f"{path}.modulation", out.modulation, "needs a [driver] (it follows the crank angle)")
    out.threshold = _num(ld, "threshold", path, "rad", 0.0)
    if out.modulation == "angle_threshold" and "threshold" not in ld:
        raise SceneError(f"{path}.threshold", _MISSING, "required with modulation = \"angle_threshold\" (rad)")
    out.table_angles = _numbers(ld.get("table_angles", []), f"{path}.table_angles", "rad")
    out.table_values = _numbers(ld.get("table_values", []), f"{path}.table_values")
    if out.modulation == "crank_table":
        a, v = out.table_angles, out.table_values
        if len(a) < 2:
            raise SceneError(f"{path}.table_angles", ld.get("table_angles", _MISSING),
                             "crank_table needs at least 2 angles (rad)")
        if any(not 0.0 <= x <= TWO_PI for x in a) or any(not y > x for x, y in zip(a, a[1:])):
            raise SceneError(f"{path}.table_angles", ld.get("table_angles"),
                             "must be strictly increasing within [0, 2 pi] (rad)")
        if len(v) != len(a):
            raise SceneError(f"{path}.table_values", ld.get("table_values", _MISSING),
                             f"must have as many entries as table_angles ({len(a)})")
    return out


def _check_connected(bodies: dict, joints: dict) -> None:
    adj: dict[str, set] = {GROUND: set(), **{b: set() for b in bodies}}
    for j in joints.values():
        a, b = j.bodies
        adj[a].add(b)
        adj[b].add(a)
    for b in bodies:
        if not adj[b]:
            raise SceneError(f"bodies.{b}", b, "is in no joint: every body must be connected to the mechanism "
                             "by at least one joint")
    seen, stack = {GROUND}, [GROUND]
    while stack:
        for v in adj[stack.pop()]:
            if v not in seen:
                seen.add(v)
                stack.append(v)
    for b in bodies:
        if b not in seen:
            group = sorted(_component(adj, b))
            raise SceneError(f"bodies.{b}", b, "is not connected to the ground through joints (its group: "
                             + ", ".join(group) + ")")


def _component(adj, start) -> set:
    seen, stack = {start}, [start]
    while stack:
        for v in adj[stack.pop()]:
            if v not in seen:
                seen.add(v)
                stack.append(v)
    return seen


# ---------------------------------------------------------------------------------------------------
# scene_to_dict, format_scene, validate


def _plain(v):
    if hasattr(v, "tolist") and not isinstance(v, (str, bytes)):
        v = v.tolist()
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    return v


def _dataclass_dict(obj, keys, skip_none=True) -> dict:
    out = {}
    for k in keys:
        v = getattr(obj, k, None)
        if v is None and skip_none:
            continue
        out[k] = _plain(v)
    return out


def scene_to_dict(scene: Scene) -> dict:
    """The fully resolved scene as plain dicts/lists in the structure of the TOML file.

    Defaults are filled in; fields that do not apply (contact and friction of an ideal joint, the axis
    of a revolute joint, fields of another load type) are written only when they differ from their
    default, so that the round trip is exact and :func:`validate` reports misplaced values. ``scene.source`` is the
    file the scene came from, if any.
    """
    st = {"name": scene.name, "description": scene.description, "gravity": _plain(scene.gravity)}
    if scene.source:
        st["source"] = scene.source
    if scene.method:
        st["method"] = scene.method
    if scene.rtol is not None:
        st["rtol"] = scene.rtol
    out: dict = {"scene": st, "ground": {"points": _plain(dict(scene.ground_points))}}
    out["bodies"] = {name: {"mass": b.mass, "inertia": b.inertia, "points": _plain(dict(b.points)),
                            "angle0": b.angle0} for name, b in scene.bodies.items()}
    joints = {}
    dc, df = Contact(), Friction()
    for name, j in scene.joints.items():
        d = {"type": j.type, "bodies": _plain(j.bodies), "points": _plain(j.points)}
        revolute = j.type == "revolute"
        if revolute or j.clearance != 0.0 or j.journal_radius != 0.0:
            d["clearance"] = j.clearance
            d["journal_radius"] = j.journal_radius
        if not revolute or tuple(j.axis) != (1.0, 0.0):
            d["axis"] = _plain(j.axis)
        if j.has_clearance or j.contact != dc:
            d["contact"] = _dataclass_dict(j.contact, CONTACT_KEYS)
        if j.has_clearance or j.friction != df:
            d["friction"] = _dataclass_dict(j.friction, FRICTION_KEYS)
        joints[name] = d
    out["joints"] = joints
    if scene.driver is not None:
        out["driver"] = _dataclass_dict(scene.driver, DRIVER_KEYS, skip_none=False)
    ctl = scene.controller
    file_loads = [ld for i, ld in enumerate(scene.loads) if ctl is None or i != ctl.load]
    if file_loads:
        out["loads"] = [_load_dict(ld) for ld in file_loads]
    if ctl is not None:
        out["controller"] = _dataclass_dict(ctl, CONTROLLER_KEYS)
    return out


def _load_dict(ld: Load) -> dict:
    dflt = vars(Load(type=""))
    relevant = LOAD_KEYS_BY_TYPE.get(ld.type, ("type",))
    d = {}
    for k in ("type",) + LOAD_KEYS[1:]:
        v = getattr(ld, k)
        if k in ("threshold",):
            keep = ld.modulation == "angle_threshold" or v != dflt[k]
        elif k in ("table_angles", "table_values"):
            keep = ld.modulation == "crank_table" or tuple(v) != ()
        elif k in relevant:
            keep = True
        else:
            keep = _plain(v) != _plain(dflt.get(k))
        if keep:
            d[k] = _plain(v)
    return d


def validate(scene: Scene) -> Scene:
    """Check a scene built in Python with the same rules as a file; returns the resolved scene
    (floats, tuples, normalised axes). Raises SceneError."""
    if not isinstance(scene, Scene):
        raise SceneError("scene", scene, "must be an nld Scene")
    for kind, table in (("bodies", scene.bodies), ("joints", scene.joints)):
        if not isinstance(table, dict):
            raise SceneError(kind, table, "must be a dict name -> object")
        for key, obj in table.items():
            if getattr(obj, "name", key) != key:
                raise SceneError(f"{kind}.{key}.name", obj.name, f"must equal its key {key!r} in Scene.{kind}")
    return scene_from_dict(scene_to_dict(scene), source=scene.source)


_UNITS = {
    "scene.gravity": "m/s^2",
    "ground.points.*": "m",
    "bodies.*.mass": "kg", "bodies.*.inertia": "kg m^2", "bodies.*.points.*": "m", "bodies.*.angle0": "rad",
    "joints.*.clearance": "m", "joints.*.journal_radius": "m", "joints.*.axis": "- (unit vector)",
    "joints.*.contact.stiffness": "N/m^n", "joints.*.contact.young": "Pa", "joints.*.contact.poisson": "-",
    "joints.*.contact.exponent": "-", "joints.*.contact.restitution": "-",
    "joints.*.contact.damping": "N s/m", "joints.*.contact.min_approach_velocity": "m/s",
    "joints.*.friction.mu": "-", "joints.*.friction.mu_s": "-", "joints.*.friction.v0": "m/s", "joints.*.friction.v1": "m/s",
    "joints.*.friction.tangential_damping": "N s/m",
    "driver.speed": "rad/s", "driver.angle0": "rad", "driver.inertia": "kg m^2", "driver.torque": "N m",
    "driver.torque_slope": "N m s/rad",
    "loads.*.threshold": "rad", "loads.*.table_angles": "rad", "loads.*.table_values": "-",
    "loads.*.stiffness": "N/m", "loads.*.free_length": "m", "loads.*.damping": "N s/m",
    "controller.delay": "s", "controller.memory": "-", "controller.offset": "N m",
    "controller.u_max": "N m",
}


def _unit_of(parts: list[str], value, loads: list) -> str:
    if parts[0] == "loads" and parts[-1] == "value":
        return "N m" if loads[int(parts[1])].get("type") == "torque" else "N"
    for pattern, unit in _UNITS.items():
        pp = pattern.split(".")
        if len(pp) == len(parts) and all(a == "*" or a == b for a, b in zip(pp, parts)):
            return unit
    return ""


def _fmt_value(v) -> str:
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        if not math.isfinite(v) or v == 0.0 or 1e-4 <= abs(v) < 1e6:
            return repr(v)
        for prec in range(1, 18):     # very large/small: shortest %g form that reads back exactly
            t = f"{v:.{prec}g}"
            if float(t) == v:
                return t
        return repr(v)
    if isinstance(v, list):
        return "[" + ", ".join(_fmt_value(x) for x in v) + "]"
    return repr(v)


def format_scene(scene: Scene) -> str:
    """Readable listing of the resolved scene, one ``path = value unit`` line per value."""
    d = scene_to_dict(scene)
    loads = d.get("loads", [])
    lines = [f"# scene {scene.name}" + (f" ({scene.source})" if scene.source else "")]

    def walk(prefix: list[str], node):
        if isinstance(node, dict) and (node or len(prefix) < 2):
            for k, v in node.items():
                walk(prefix + [str(k)], v)
            return
        if isinstance(node, list) and prefix == ["loads"]:
            for i, v in enumerate(node):
                walk(prefix + [str(i)], v)
            return
        path = ".".join(prefix)
        if isinstance(node, dict):   # an empty table, e.g. no ground points
            lines.append(f"{path} = {{}}")
            return
        unit = _unit_of(prefix, node, loads)
        if unit == "N/m^n":
            j = d["joints"][prefix[1]]
            unit = f"N/m^{j['contact'].get('exponent', 1.5):g}"
        lines.append(f"{path} = {_fmt_value(node)}" + (f" {unit}" if unit else ""))
        if (len(prefix) == 4 and prefix[0] == "joints" and prefix[2] == "contact" and prefix[3] == "law"
                and "stiffness" not in node_parent(prefix)):
            derived = _derived_stiffness(scene, prefix[1])
            if derived is not None:
                n = d["joints"][prefix[1]]["contact"].get("exponent", 1.5)
                lines.append(f"{'.'.join(prefix[:3])}.stiffness = {_fmt_value(derived)} N/m^{n:g}"
                             "  # from young, poisson and the radii")

    def node_parent(prefix):
        node = d
        for p in prefix[:-1]:
            node = node[int(p)] if isinstance(node, list) else node[p]
        return node

    walk([], d)
    return "\n".join(lines)


def _derived_stiffness(scene: Scene, joint: str):
    """Contact stiffness computed from E, nu and the radii, for the listing (None if unavailable)."""
    j = scene.joints.get(joint)
    if j is None or not j.has_clearance or j.contact.stiffness is not None:
        return None
    try:
        from nld.model.parameters import contact_stiffness   # lazy: imports numba
        return float(contact_stiffness(j))
    except Exception:   # noqa: BLE001 - the listing must not fail on an optional extra line
        return None
