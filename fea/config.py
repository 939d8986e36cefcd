"""LINK.toml: one FEA-to-stiffness job (format: docs/link.md).

:func:`load_link` reads and checks the file and returns a :class:`LinkJob`
whose lengths are in metres (the file's ``geometry.units`` converted at this
boundary). Every problem raises :class:`ConfigError` naming the file, the
key and what was wrong.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import InputError
from ..io.tables import read_toml

UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "in": 0.0254}
PLANES = ("x-min", "x-max", "y-min", "y-max", "z-min", "z-max")
ROUTES = ("auto", "ccx", "matrix")
COUPLINGS = ("distributing", "rigid")
REGIONS = ("face", "cube", "layer")
FIT_METHODS = ("lin", "svd+", "svd-", "svd+-", "exact")


def paper_beam(size_mm: float = 5.0, route: str = "matrix") -> dict:
    """LINK.toml data of the paper's illustrative beam (Pashkevich 2009 s4.1):
    1000 x 10 x 10 mm, E = 2e5 N/mm^2, nu = 0.266, clamped at x = 0, loaded
    at the tip through a distributing coupling, tip-face field, C3D10. A new
    dict on every call (callers change it)."""
    return {
        "geometry": {"shape": "box", "size": [1000.0, 10.0, 10.0], "units": "mm"},
        "material": {"E": 2.0e11, "nu": 0.266},
        "support": {"plane": "x-min"},
        "load": {
            "plane": "x-max",
            "reference_point": [1000.0, 0.0, 0.0],
            "coupling": "distributing",
            "amplitudes": "auto",
        },
        "field": {"region": "face"},
        "mesh": {"mesher": "gmsh", "order": 2, "size": float(size_mm)},
        "fit": {"method": "lin", "trim": 0.0, "confidence": 0.99},
        "solver": {"route": route},
    }


class ConfigError(InputError):
    """LINK.toml is missing, malformed or has an invalid value."""


@dataclass
class LinkJob:
    """A checked LINK.toml; lengths in metres unless named *_units."""

    source: str
    geometry: dict  # shape/size/... in geometry units, or step (absolute path)
    units: str
    scale: float  # geometry unit -> m
    E: float
    nu: float
    density: float
    support_plane: str
    load_plane: str
    reference_point: list  # m
    coupling: str
    amplitudes: object  # "auto" or [6 floats] N, N m
    region: str
    region_size: float  # m
    mesher: str
    order: int
    size: float  # geometry units
    refine: float | None
    refine_radius: float | None  # geometry units
    optimize: str  # none | netgen
    method: str
    trim: float
    confidence: float
    symmetrize: bool
    route: str
    plane_tolerance: float | None  # m
    ccx_timeout: float
    approximation: dict | None = None  # single-beam approximation: length (m), section, dims (m)
    pooled: bool = True  # one noise estimate for the six fields (paper s3.4)
    structured: bool = False  # transfinite tet mesh (built-in box only)
    across_factor: float = 1.0  # structured: element size across the section / size
    raw: dict = field(default_factory=dict)

    @property
    def size_m(self) -> float:
        return self.size * self.scale

    def with_mesh(self, order: int | None = None, size: float | None = None) -> LinkJob:
        job = copy.deepcopy(self)
        if order is not None:
            job.order = int(order)
        if size is not None:
            job.size = float(size)
        return job

    def closed_form_shape(self):
        """(length m, section name, dims m) of the beam to compare with: the
        [approximation] given in LINK.toml (a single-beam approximation), or
        the built-in straight cantilever loaded at its free end centre; else None."""
        if self.approximation is not None:
            a = self.approximation
            return a["length"], a["section"], a["dims"]
        g = self.geometry
        if self.support_plane != "x-min" or self.load_plane != "x-max":
            return None
        if g.get("shape") == "box":
            L, b, h = (v * self.scale for v in g["size"])
            sec = ("rectangle", [b, h])
        elif g.get("shape") in ("tube", "rod"):
            L = g["length"] * self.scale
            d = g.get("inner_diameter", 0.0) * self.scale if g["shape"] == "tube" else 0.0
            sec = (
                ("tube", [g["outer_diameter"] * self.scale, d])
                if d > 0
                else ("circle", [g["outer_diameter"] * self.scale])
            )
        else:
            return None
        if any(abs(a - b) > 1e-9 * L for a, b in zip(self.reference_point, [L, 0.0, 0.0])):
            return None
        return L, sec[0], sec[1]


def _get(tbl: dict, key: str, where: str, path: str, kind=None, default=...):
    if key not in tbl:
        if default is ...:
            raise ConfigError(f"{path}: [{where}] {key} is missing")
        return default
    v = tbl[key]
    if kind is float:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ConfigError(f"{path}: [{where}] {key} = {v!r} must be a finite number")
        return float(v)
    if kind is int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise ConfigError(f"{path}: [{where}] {key} = {v!r} must be an integer")
        return v
    if kind is str:
        if not isinstance(v, str):
            raise ConfigError(f"{path}: [{where}] {key} = {v!r} must be a string")
        return v
    if kind is list:
        if not isinstance(v, list) or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v
        ):
            raise ConfigError(f"{path}: [{where}] {key} = {v!r} must be a list of numbers")
        return [float(x) for x in v]
    return v


def _choice(v, choices, where, key, path):
    if v not in choices:
        raise ConfigError(f"{path}: [{where}] {key} = {v!r}: choose one of {', '.join(map(str, choices))}")
    return v


def _positive(v, where, key, path):
    if not v > 0:
        raise ConfigError(f"{path}: [{where}] {key} = {v!r} must be positive")
    return v


def parse_link(data: dict, path: str = "LINK.toml", base: Path | None = None) -> LinkJob:
    """Check a LINK.toml already parsed into a dict."""
    base = base or Path(".")
    for section in ("geometry", "material", "support", "load"):
        if section not in data or not isinstance(data[section], dict):
            raise ConfigError(f"{path}: section [{section}] is missing")
    known = {"geometry", "material", "support", "load", "field", "mesh", "fit", "solver", "approximation"}
    unknown = set(data) - known
    if unknown:
        raise ConfigError(f"{path}: unknown section(s) {', '.join(sorted(unknown))}; known: {', '.join(sorted(known))}")
    g = data["geometry"]
    units = _get(g, "units", "geometry", path, str, "mm")
    if units not in UNITS:
        raise ConfigError(f"{path}: [geometry] units = {units!r}: one of {', '.join(UNITS)}")
    scale = UNITS[units]
    geometry: dict = {}
    if "step" in g and "shape" in g:
        raise ConfigError(f"{path}: [geometry] give either step (a CAD file) or shape, not both")
    if "step" in g:
        f = Path(_get(g, "step", "geometry", path, str))
        f = f if f.is_absolute() else (base / f)
        if not f.is_file():
            raise ConfigError(f"{path}: [geometry] step = {g['step']!r}: file not found ({f})")
        geometry["step"] = str(f.resolve())
    elif "shape" in g:
        shape = _choice(g["shape"], ("box", "tube", "rod"), "geometry", "shape", path)
        geometry["shape"] = shape
        if shape == "box":
            size = _get(g, "size", "geometry", path, list)
            if len(size) != 3 or min(size) <= 0:
                raise ConfigError(f"{path}: [geometry] size = {size!r}: three positive lengths [along x, y, z]")
            geometry["size"] = size
        else:
            geometry["length"] = _positive(_get(g, "length", "geometry", path, float), "geometry", "length", path)
            geometry["outer_diameter"] = _positive(
                _get(g, "outer_diameter", "geometry", path, float), "geometry", "outer_diameter", path
            )
            if shape == "tube":
                d = _get(g, "inner_diameter", "geometry", path, float)
                if not 0 < d < geometry["outer_diameter"]:
                    raise ConfigError(
                        f"{path}: [geometry] inner_diameter = {d!r} must lie in "
                        f"(0, outer_diameter = {geometry['outer_diameter']})"
                    )
                geometry["inner_diameter"] = d
    else:
        raise ConfigError(f'{path}: [geometry] needs step = "part.step" or shape = "box" | "tube" | "rod"')

    m = data["material"]
    E = _positive(_get(m, "E", "material", path, float), "material", "E", path)
    nu = _get(m, "nu", "material", path, float)
    if not -1.0 < nu < 0.5:
        raise ConfigError(f"{path}: [material] nu = {nu!r} must lie in (-1, 0.5)")
    density = _positive(_get(m, "density", "material", path, float, 7850.0), "material", "density", path)

    sup = _choice(_get(data["support"], "plane", "support", path, str), PLANES, "support", "plane", path)
    ld = data["load"]
    lplane = _choice(_get(ld, "plane", "load", path, str), PLANES, "load", "plane", path)
    if lplane == sup:
        raise ConfigError(
            f"{path}: [load] plane = {lplane!r} is also the support plane: the load "
            "face must differ from the clamped face"
        )
    ref = _get(ld, "reference_point", "load", path, list)
    if len(ref) != 3:
        raise ConfigError(f"{path}: [load] reference_point = {ref!r}: three coordinates")
    coupling = _choice(_get(ld, "coupling", "load", path, str, "distributing"), COUPLINGS, "load", "coupling", path)
    amps = ld.get("amplitudes", "auto")
    if amps != "auto":
        amps = _get(ld, "amplitudes", "load", path, list)
        if len(amps) != 6 or min(amps) <= 0:
            raise ConfigError(
                f'{path}: [load] amplitudes = {amps!r}: "auto" or six positive '
                "numbers [Fx, Fy, Fz, Mx, My, Mz] in N and N m"
            )
    fl = data.get("field", {})
    region = _choice(_get(fl, "region", "field", path, str, "face"), REGIONS, "field", "region", path)
    rsize = _get(fl, "size", "field", path, float, 0.0)
    if region != "face":
        _positive(rsize, "field", "size", path)
    me = data.get("mesh", {})
    mesher = _choice(_get(me, "mesher", "mesh", path, str, "gmsh"), ("gmsh", "tetgen"), "mesh", "mesher", path)
    order = _choice(_get(me, "order", "mesh", path, int, 2), (1, 2), "mesh", "order", path)
    msize = _positive(_get(me, "size", "mesh", path, float), "mesh", "size", path)
    refine = _get(me, "refine", "mesh", path, float, None) if "refine" in me else None
    if refine is not None and not 0 < refine < 1:
        raise ConfigError(f"{path}: [mesh] refine = {refine!r}: a size factor in (0, 1)")
    rr = _get(me, "refine_radius", "mesh", path, float, None) if "refine_radius" in me else None
    optimize = _choice(_get(me, "optimize", "mesh", path, str, "none"), ("none", "netgen"), "mesh", "optimize", path)
    structured = me.get("structured", False)
    if not isinstance(structured, bool):
        raise ConfigError(f"{path}: [mesh] structured = {structured!r}: true or false")
    across = _get(me, "across_factor", "mesh", path, float, 1.0)
    if not 0 < across <= 1:
        raise ConfigError(f"{path}: [mesh] across_factor = {across!r}: a size factor in (0, 1]")
    if "across_factor" in me and not structured:
        raise ConfigError(f"{path}: [mesh] across_factor needs structured = true")
    if structured:
        if geometry.get("shape") != "box":
            raise ConfigError(
                f"{path}: [mesh] structured = true is only for the built-in "
                f'[geometry] shape = "box", not '
                f"{geometry.get('shape') or 'step = ' + repr(g.get('step'))}"
            )
        if mesher != "gmsh":
            raise ConfigError(f'{path}: [mesh] structured = true needs mesher = "gmsh", not {mesher!r}')
        if refine is not None:
            raise ConfigError(
                f"{path}: [mesh] structured = true and refine exclude each other "
                "(a structured mesh has one size along and one across)"
            )
        if optimize != "none":
            raise ConfigError(
                f'{path}: [mesh] structured = true needs optimize = "none" (the optimiser would unstructure it)'
            )
    fit = data.get("fit", {})
    method = _choice(_get(fit, "method", "fit", path, str, "lin"), FIT_METHODS, "fit", "method", path)
    trim = _get(fit, "trim", "fit", path, float, 0.0)
    if not 0 <= trim < 0.5:
        raise ConfigError(f"{path}: [fit] trim = {trim!r}: a fraction in [0, 0.5)")
    conf = _get(fit, "confidence", "fit", path, float, 0.99)
    if not 0 < conf < 1:
        raise ConfigError(f"{path}: [fit] confidence = {conf!r}: a level in (0, 1)")
    sym = fit.get("symmetrize", False)
    if not isinstance(sym, bool):
        raise ConfigError(f"{path}: [fit] symmetrize = {sym!r}: true or false")
    pooled = fit.get("pooled", True)
    if not isinstance(pooled, bool):
        raise ConfigError(f"{path}: [fit] pooled = {pooled!r}: true or false")
    so = data.get("solver", {})
    route = _choice(_get(so, "route", "solver", path, str, "auto"), ROUTES, "solver", "route", path)
    timeout = _positive(_get(so, "timeout", "solver", path, float, 3600.0), "solver", "timeout", path)
    tol = _get(data["support"], "tolerance", "support", path, float, None) if "tolerance" in data["support"] else None
    approx = None
    if "approximation" in data:
        ap = data["approximation"]
        sec = _choice(
            _get(ap, "section", "approximation", path, str),
            ("rectangle", "square", "tube", "circle"),
            "approximation",
            "section",
            path,
        )
        dims = _get(ap, "dims", "approximation", path, list)
        if not dims or min(dims) < 0:
            raise ConfigError(f"{path}: [approximation] dims = {dims!r}: section sizes in {units}")
        length = _positive(_get(ap, "length", "approximation", path, float), "approximation", "length", path)
        approx = {"length": length * scale, "section": sec, "dims": [d * scale for d in dims]}
    return LinkJob(
        source=path,
        geometry=geometry,
        units=units,
        scale=scale,
        E=E,
        nu=nu,
        density=density,
        support_plane=sup,
        load_plane=lplane,
        reference_point=[v * scale for v in ref],
        coupling=coupling,
        amplitudes=amps,
        region=region,
        region_size=rsize * scale,
        mesher=mesher,
        order=order,
        size=msize,
        refine=refine,
        refine_radius=rr,
        optimize=optimize,
        method=method,
        trim=trim,
        confidence=conf,
        symmetrize=sym,
        route=route,
        plane_tolerance=None if tol is None else tol * scale,
        ccx_timeout=timeout,
        approximation=approx,
        pooled=pooled,
        structured=structured,
        across_factor=across,
        raw=data,
    )


def load_link(path) -> LinkJob:
    """Read and check LINK.toml (see the module docstring)."""
    p = Path(path)
    data = read_toml(p, "LINK.toml", error=ConfigError)
    return parse_link(data, str(p), p.resolve().parent)
