"""The runs of a sweep: ``--vary KEY=V1,V2,...`` overrides of LINK.toml keys.

A key is a dotted path into LINK.toml: ``section.key`` (``material.E``,
``mesh.size``), an element of a list ``section.key.INDEX`` (or
``section.key[INDEX]``: ``geometry.size.0`` is a box's length), or the
derived key ``geometry.wall`` of a tube (``inner_diameter = outer_diameter
- 2 wall``). Every key is checked against :data:`SCHEMA` (the keys
:func:`stiffkit.fea.config.parse_link` reads, with their types), every value
is converted to its key's type, and every run's LINK data is checked by
``parse_link`` itself, all before anything runs; a problem raises
:class:`PlanError` (one line naming the key and the value).

One ``--vary`` is one axis of the sweep. Several ``KEY=VALUES`` in the same
``--vary``, separated by spaces, move together (the same number of values),
e.g. a beam's length and its reference point:
``--vary "geometry.size.0=100,200 load.reference_point.0=100,200"``. The runs
are the Cartesian product of the axes (the first axis varies slowest), or,
with ``zip``, the axes side by side (all of the same length).
"""

from __future__ import annotations

import copy
import itertools
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

try:  # Python >= 3.11
    import tomllib
except ImportError:  # pragma: no cover
    import tomli as tomllib  # type: ignore

from ..errors import InputError
from ..fea.config import ConfigError, LinkJob, parse_link

#: LINK.toml keys by section and their types: float, int, str, bool, list
#: (of numbers; ``list3`` of three), amplitudes ("auto" or six numbers).
#: Kept in step with fea/config.py:parse_link (tests/test_sweep.py checks it).
SCHEMA: dict[str, dict[str, str]] = {
    "geometry": {
        "step": "str",
        "shape": "str",
        "units": "str",
        "size": "list3",
        "length": "float",
        "outer_diameter": "float",
        "inner_diameter": "float",
    },
    "material": {"E": "float", "nu": "float", "density": "float"},
    "support": {"plane": "str", "tolerance": "float", "coupling": "str"},
    "load": {"plane": "str", "reference_point": "list3", "coupling": "str", "amplitudes": "amplitudes"},
    "field": {"region": "str", "size": "float"},
    "mesh": {
        "mesher": "str",
        "element": "str",
        "order": "int",
        "size": "float",
        "refine": "float",
        "refine_radius": "float",
        "optimize": "str",
        "structured": "bool",
        "across_factor": "float",
        "features": "bool",
        "across": "int",
        "around": "int",
        "accuracy": "float",
        "max_nodes": "int",
    },
    "fit": {"method": "str", "trim": "float", "confidence": "float", "symmetrize": "bool", "pooled": "bool"},
    "solver": {"route": "str", "timeout": "float"},
    "approximation": {"section": "str", "dims": "list", "length": "float"},
}
#: keys computed from others (not in LINK.toml): name -> (kind, shapes it applies to)
#: most runs in one sweep (a plan, or a --dry-run listing, of more is refused)
MAX_RUNS = 10_000

DERIVED = {("geometry", "wall"): ("float", ("tube",))}
#: geometry keys that a shape reads (the others would be ignored silently)
SHAPE_KEYS = {
    "box": {"size"},
    "tube": {"length", "outer_diameter", "inner_diameter", "wall"},
    "rod": {"length", "outer_diameter"},
}
KIND_TEXT = {
    "float": "a finite number",
    "int": "an integer",
    "str": "a word or path",
    "bool": "true or false",
    "list": "a list of numbers [a,b,...]",
    "list3": "a list of three numbers [x,y,z]",
    "amplitudes": '"auto" or six numbers [Fx,Fy,Fz,Mx,My,Mz]',
}


class PlanError(InputError):
    """A --vary argument or a run built from it is invalid."""


@dataclass(frozen=True)
class Key:
    """A checked dotted key: section, name, optional list index."""

    text: str  # canonical: section.key or section.key.INDEX
    section: str
    name: str
    index: int | None
    kind: str  # value kind (for an indexed key: float)
    derived: bool = False


@dataclass
class Axis:
    keys: list[Key]
    values: list[list]  # values[k] are the values of keys[k]

    def __len__(self) -> int:
        return len(self.values[0])


@dataclass
class Run:
    index: int  # 1-based, plan order
    overrides: dict  # key text -> value
    data: dict  # the run's LINK data (overrides applied)
    job: object = None  # its checked LinkJob
    label: str = ""

    def describe(self) -> str:
        return " ".join(f"{k}={fmt_value(v)}" for k, v in self.overrides.items())


@dataclass
class Plan:
    source: str
    base: Path
    data: dict
    axes: list[Axis]
    zipped: bool
    runs: list[Run] = field(default_factory=list)

    @property
    def keys(self) -> list[str]:
        return [k.text for a in self.axes for k in a.keys]


def fmt_value(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, list):
        return "[" + ",".join(fmt_value(x) for x in v) + "]"
    return str(v)


_KEY = re.compile(r"^([A-Za-z_]\w*)\.([A-Za-z_]\w*)(?:\.(\d+)|\[(\d+)\])?$")


def parse_key(text: str, what: str = "--vary") -> Key:
    """Check a dotted key against the schema."""
    t = text.strip()
    m = _KEY.match(t)
    if not m:
        raise PlanError(
            f"{what} {text!r}: a key is section.key, e.g. mesh.size, material.E or "
            "geometry.size.0 (an element of a list)"
        )
    section, name = m.group(1), m.group(2)
    idx = m.group(3) if m.group(3) is not None else m.group(4)
    index = int(idx) if idx is not None else None
    if section not in SCHEMA:
        raise PlanError(f"{what} {t}: unknown section [{section}]; sections: {', '.join(SCHEMA)}")
    if (section, name) in DERIVED:
        kind = DERIVED[(section, name)][0]
        if index is not None:
            raise PlanError(f"{what} {t}: {section}.{name} is a number, not a list")
        return Key(f"{section}.{name}", section, name, None, kind, derived=True)
    if name not in SCHEMA[section]:
        extra = [n for (s, n) in DERIVED if s == section]
        raise PlanError(
            f"{what} {t}: unknown key {name!r} in [{section}]; keys: {', '.join(list(SCHEMA[section]) + extra)}"
        )
    kind = SCHEMA[section][name]
    if index is not None:
        if kind not in ("list", "list3", "amplitudes"):
            raise PlanError(
                f"{what} {t}: [{section}] {name} is {KIND_TEXT[kind]}, not a list: write {section}.{name}=..."
            )
        if kind == "list3" and index > 2:
            raise PlanError(f"{what} {t}: [{section}] {name} has three elements (index 0, 1, 2)")
        if kind == "amplitudes" and index > 5:
            raise PlanError(f"{what} {t}: [{section}] {name} has six elements (index 0-5)")
        return Key(f"{section}.{name}.{index}", section, name, index, "float")
    return Key(f"{section}.{name}", section, name, None, kind)


def split_values(text: str) -> list[str]:
    """Split ``a,b,[1,2,3]`` at the commas outside brackets and quotes."""
    out, depth, cur, quote = [], 0, [], None
    for ch in text:
        if quote:
            cur.append(ch)
            if ch == quote:
                quote = None
            continue
        if ch in "\"'":
            quote = ch
        elif ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        if ch == "," and depth == 0:
            out.append("".join(cur).strip())
            cur = []
        else:
            cur.append(ch)
    out.append("".join(cur).strip())
    return out


def _toml_value(tok: str) -> object:
    try:
        return tomllib.loads(f"v = {tok}")["v"]
    except tomllib.TOMLDecodeError:
        return None


def _number(v: object) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def coerce(key: Key, value: object, what: str = "--vary") -> int | float | bool | str | list[float]:
    """Convert one value (a string from the command line, or a Python value)
    to the key's type; raise PlanError naming the key and the value."""
    shown = value if isinstance(value, str) else repr(value)
    bad = PlanError(
        f"{what} {key.text}={shown}: [{key.section}] {key.name}"
        f"{'' if key.index is None else f' element {key.index}'} takes "
        f"{KIND_TEXT[key.kind]}, not {shown!r}"
    )
    if isinstance(value, str):
        tok = value.strip()
        if tok == "":
            raise PlanError(f"{what} {key.text}: an empty value (values are separated by single commas)")
        if key.kind in ("float", "int"):
            if key.kind == "int":
                if not re.fullmatch(r"[+-]?\d+", tok):
                    raise bad
                return int(tok)
            try:
                v = float(tok)
            except ValueError:
                raise bad from None
            if not math.isfinite(v):
                raise bad
            return v
        if key.kind == "bool":
            if tok.lower() in ("true", "false"):
                return tok.lower() == "true"
            raise bad
        if key.kind == "str":
            if len(tok) >= 2 and tok[0] == tok[-1] and tok[0] in "\"'":
                tok = tok[1:-1]
            return tok
        if key.kind == "amplitudes" and tok.strip("\"'") == "auto":
            return "auto"
        parsed = _toml_value(tok) if tok.startswith("[") else None
        if parsed is None:
            raise bad
        value = parsed
    # Python values (or parsed lists)
    if key.kind == "float":
        if not _number(value):
            raise bad
        return float(value)
    if key.kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise bad
        return value
    if key.kind == "bool":
        if not isinstance(value, bool):
            raise bad
        return value
    if key.kind == "str":
        if isinstance(value, Path):
            return str(value)
        if not isinstance(value, str):
            raise bad
        return value
    if key.kind == "amplitudes" and value == "auto":
        return "auto"
    if not isinstance(value, (list, tuple)) or not all(_number(x) for x in value):
        raise bad
    n = {"list3": 3, "amplitudes": 6}.get(key.kind)
    if (n is not None and len(value) != n) or len(value) == 0:
        raise bad
    return [float(x) for x in value]


def parse_vary(text: str) -> Axis:
    """One --vary argument: ``KEY=V1,V2,...`` or several such separated by
    spaces (keys that move together)."""
    parts = text.split()
    if not parts:
        raise PlanError("--vary: empty; write --vary KEY=V1,V2,... e.g. --vary mesh.size=5,3,2")
    keys, values = [], []
    for part in parts:
        if "=" not in part:
            raise PlanError(f"--vary {part!r}: write KEY=V1,V2,... e.g. --vary mesh.size=5,3,2")
        ktext, vtext = part.split("=", 1)
        key = parse_key(ktext)
        if vtext.strip() == "":
            raise PlanError(f"--vary {key.text}=: no values; give one or more, e.g. {key.text}=1,2")
        values.append([coerce(key, tok) for tok in split_values(vtext)])
        keys.append(key)
    _check_tied(keys, values, text)
    return Axis(keys, values)


def _check_tied(keys: list[Key], values: list[list], text: str) -> None:
    lens = {len(v) for v in values}
    if len(lens) > 1:
        raise PlanError(
            f"--vary {text!r}: keys that move together need the same number of values "
            f"({', '.join(f'{k.text}: {len(v)}' for k, v in zip(keys, values))})"
        )


def axes_from_python(vary: dict | Sequence[str] | str) -> list[Axis]:
    """``vary`` of :func:`stiffkit.sweep`: a dict ``{key: values}`` (one axis
    each; a value that is itself a dict ``{key: values, ...}`` is a group of
    keys moving together, the outer key being only a label), or a list of
    command-line strings ``"KEY=V1,V2"``."""
    if isinstance(vary, str):
        vary = [vary]
    if isinstance(vary, (list, tuple)):
        if not all(isinstance(v, str) for v in vary):
            raise PlanError("vary: a dict {key: values} or a list of 'KEY=V1,V2,...' strings")
        return [parse_vary(v) for v in vary]
    if not isinstance(vary, dict) or not vary:
        raise PlanError("vary: a non-empty dict {key: values}, e.g. {'mesh.size': [5, 3]}")
    axes = []
    for k, v in vary.items():
        group = v if isinstance(v, dict) else {k: v}
        keys, values = [], []
        for kk, vv in group.items():
            key = parse_key(str(kk), "vary")
            if isinstance(vv, str):
                vv = split_values(vv)
            if not isinstance(vv, (list, tuple)) or (
                key.kind in ("list", "list3", "amplitudes") and vv and _number(vv[0])
            ):
                vv = [vv]
            if len(vv) == 0:
                raise PlanError(f"vary {key.text}: no values")
            values.append([coerce(key, x, "vary") for x in vv])
            keys.append(key)
        _check_tied(keys, values, str(k))
        axes.append(Axis(keys, values))
    return axes


def _set(data: dict, key: Key, value: object, what: str) -> None:
    sec = data.setdefault(key.section, {})
    if not isinstance(sec, dict):
        raise PlanError(f"{what}: [{key.section}] is not a table in the LINK file")
    if key.index is None:
        sec[key.name] = value
        return
    lst = sec.get(key.name)
    if not isinstance(lst, list):
        raise PlanError(
            f"{what}: [{key.section}] {key.name} is "
            f"{'missing' if lst is None else repr(lst)} in the LINK file, so it has no "
            f"element {key.index}; vary the whole list ({key.section}.{key.name}=[...],[...])"
        )
    if key.index >= len(lst):
        raise PlanError(f"{what}: [{key.section}] {key.name} = {lst!r} has no element {key.index}")
    lst[key.index] = value


def apply(data: dict, overrides: list[tuple[Key, object]]) -> dict:
    """A copy of the LINK data with the overrides applied (derived keys last)."""
    out = copy.deepcopy(data)
    for key, value in sorted(overrides, key=lambda kv: kv[0].derived):
        what = f"--vary {key.text}={fmt_value(value)}"
        if key.derived:  # geometry.wall of a tube
            g = out.get("geometry", {})
            od = g.get("outer_diameter")
            if g.get("shape") != "tube" or not _number(od):
                raise PlanError(
                    f'{what}: geometry.wall is the wall of shape = "tube" (inner_diameter = outer_diameter - 2 wall)'
                )
            if not 0 < value < od / 2:
                raise PlanError(f"{what}: the wall must lie in (0, outer_diameter / 2 = {od / 2:g})")
            g["inner_diameter"] = od - 2 * value
            continue
        _set(out, key, value, what)
    return out


def _no_effect(data: dict, overrides: list[tuple[Key, object]]) -> None:
    """A varied key that this run's LINK data would ignore is an error (the
    runs would all be the same)."""
    g = data.get("geometry", {})
    shape = "step" if "step" in g else g.get("shape")
    for key, value in overrides:
        what = f"--vary {key.text}={fmt_value(value)}"
        if key.section == "geometry" and key.name not in ("units", "step", "shape"):
            if shape not in SHAPE_KEYS or key.name not in SHAPE_KEYS[shape]:
                reads = sorted(SHAPE_KEYS.get(shape, set())) if shape in SHAPE_KEYS else ["step"]
                raise PlanError(
                    f"{what}: [geometry] {key.name} has no effect on "
                    f"{'a CAD file' if shape == 'step' else f'shape = {shape!r}'} "
                    f"(it reads {', '.join(reads + ['units'])})"
                )
        if key.text == "field.size" and data.get("field", {}).get("region", "face") == "face":
            raise PlanError(
                f'{what}: [field] size has no effect with region = "face" '
                "(vary field.region too, or set it to cube or layer)"
            )
        if key.text == "mesh.refine_radius" and "refine" not in data.get("mesh", {}):
            raise PlanError(f"{what}: [mesh] refine_radius has no effect without [mesh] refine")


def read_link(link: Path | str | dict) -> tuple[dict, str, Path]:
    """(LINK data, source name, base folder for relative paths)."""
    if isinstance(link, dict):
        return copy.deepcopy(link), "LINK", Path.cwd()
    p = Path(link)
    if not p.is_file():
        raise ConfigError(f"{p}: no such LINK.toml file")
    try:
        data = tomllib.loads(p.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{p}: not valid TOML ({exc})") from None
    return data, str(p), p.resolve().parent


def _check_run(data: dict, overrides: list[tuple[Key, object]], source: str, base: Path, what: str) -> LinkJob:
    _no_effect(data, overrides)
    try:
        return parse_link(data, source, base)
    except ConfigError as exc:
        raise PlanError(f"{what}: {exc}") from None


def make_plan(link: Path | str | dict, axes: list[Axis], zipped: bool = False) -> Plan:
    """Every run of the sweep with its checked LinkJob (nothing runs)."""
    data, source, base = read_link(link)
    if not axes:
        raise PlanError("--vary: at least one, e.g. --vary mesh.size=5,3,2")
    seen: dict[tuple, str] = {}
    for axis in axes:
        for k in axis.keys:
            name = "inner_diameter" if k.text == "geometry.wall" else k.name
            clash = [
                t
                for (sec, n, i), t in seen.items()
                if (sec, n) == (k.section, name) and (i is None or k.index is None or i == k.index)
            ]
            if clash:
                raise PlanError(f"--vary {k.text}: {clash[0]} is varied already (each key in one --vary)")
            seen[(k.section, name, k.index)] = k.text
    # at most MAX_RUNS runs, checked before any run is built (or listed)
    count = max(len(a) for a in axes) if zipped else math.prod(len(a) for a in axes)
    if count > MAX_RUNS:
        sizes = (", " if zipped else " x ").join(f"{len(a)} ({a.keys[0].text})" for a in axes)
        raise PlanError(
            f"--vary: {count} runs ({'zipped: ' if zipped else ''}{sizes}); a sweep has at most {MAX_RUNS} runs "
            f"(--dry-run too): vary fewer values, or split it into several sweeps (they share the cache)"
        )
    # each value with every other axis at its first value: an error then names
    # that key and value (when that reference run itself is valid)
    first = [(k, a.values[j][0]) for a in axes for j, k in enumerate(a.keys)]
    try:
        ref_ok = not _single_key_error(apply(data, first), first, source, base)
    except PlanError:
        ref_ok = False
    if ref_ok:
        for a in axes:
            for i in range(1, len(a)):
                mine = [(k, a.values[j][i]) for j, k in enumerate(a.keys)]
                ov = [(k, v) for k, v in first if k not in a.keys] + mine
                what = "--vary " + " ".join(f"{k.text}={fmt_value(v)}" for k, v in mine)
                run_data = apply(data, ov)
                if _single_key_error(run_data, ov, source, base):
                    _check_run(run_data, mine, source, base, what)
                    _check_run(run_data, ov, source, base, what)
    if zipped:
        n = {len(a) for a in axes}
        if len(n) > 1:
            raise PlanError(
                "--zip: every --vary needs the same number of values ("
                + ", ".join(f"{a.keys[0].text}: {len(a)}" for a in axes)
                + ")"
            )
        count = len(axes[0])
    else:
        count = math.prod(len(a) for a in axes)
    if count > MAX_RUNS:
        sizes = " x ".join(f"{len(a)} ({a.keys[0].text})" for a in axes)
        raise PlanError(
            f"--vary: {count} runs ({'zipped, ' if zipped else ''}{sizes}); a sweep has at most {MAX_RUNS} runs: "
            f"vary fewer values, or split it into several sweeps (they share the cache)"
        )
    if zipped:
        combos = [tuple([i] * len(axes)) for i in range(len(axes[0]))]
    else:
        combos = list(itertools.product(*[range(len(a)) for a in axes]))
    plan = Plan(source=source, base=base, data=data, axes=axes, zipped=zipped)
    for n, combo in enumerate(combos, 1):
        ov = [(k, a.values[j][i]) for a, i in zip(axes, combo) for j, k in enumerate(a.keys)]
        overrides = {k.text: v for k, v in ov}
        what = f"run {n} ({' '.join(f'{k}={fmt_value(v)}' for k, v in overrides.items())})"
        run_data = apply(data, ov)
        if _single_key_error(run_data, ov, source, base):
            _blame(data, ov, source, base)
        job = _check_run(run_data, ov, source, base, what)
        plan.runs.append(
            Run(
                index=n,
                overrides=overrides,
                data=run_data,
                job=job,
                label=" ".join(f"{k}={fmt_value(v)}" for k, v in overrides.items()),
            )
        )
    return plan


def _blame(data: dict, ov: list[tuple[Key, object]], source: str, base: Path) -> None:
    """When a run is invalid and the base with one of its values alone is
    too (but the base without it is not), name that key and value."""
    if _single_key_error(data, [], source, base):
        return
    for k, v in ov:
        try:
            alone = apply(data, [(k, v)])
        except PlanError:
            continue
        if _single_key_error(alone, [(k, v)], source, base):
            _check_run(alone, [(k, v)], source, base, f"--vary {k.text}={fmt_value(v)}")


def _single_key_error(run_data: dict, ov: list[tuple[Key, object]], source: str, base: Path) -> bool:
    try:
        _no_effect(run_data, ov)
        parse_link(run_data, source, base)
    except (ConfigError, PlanError):
        return True
    return False


__all__ = [
    "MAX_RUNS",
    "SCHEMA",
    "DERIVED",
    "PlanError",
    "Key",
    "Axis",
    "Run",
    "Plan",
    "parse_key",
    "parse_vary",
    "coerce",
    "split_values",
    "axes_from_python",
    "apply",
    "make_plan",
    "read_link",
    "fmt_value",
]
