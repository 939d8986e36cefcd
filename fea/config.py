"""LINK.toml: one FEA-to-stiffness job (format: docs/link.md).

:func:`load_link` reads and checks the file and returns a :class:`LinkJob`
whose lengths are in metres (the file's ``geometry.units`` converted at this
boundary). Every problem raises :class:`ConfigError` naming the file, the
key and what was wrong.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path

from ..io import validate as V
from ..io.tables import read_toml
from ..meshing.mesh import ELEMENT_NODES
from ..meshing.refine import AROUND, default_across
from .meshkeys import MAX_NODES, MESH_KEYS, check_mesh_keys
from .selectors import KINDS, Selector, SelectorError, cad_selectors, parse_set, planes_of
from .tomlvalues import ConfigError
from .tomlvalues import choice as _choice
from .tomlvalues import get_value as _get
from .tomlvalues import number as _num
from .tomlvalues import positive as _positive
from .tomlvalues import suggest as _suggest

UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "in": 0.0254}
PLANES = ("x-min", "x-max", "y-min", "y-max", "z-min", "z-max")
ROUTES = ("auto", "ccx", "matrix")
COUPLINGS = ("rigid", "distributing")
REGIONS = ("face", "cube", "layer", "faces")
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
        # the paper's plain mesh (its Table 5): no feature refinement
        "mesh": {"mesher": "gmsh", "order": 2, "size": float(size_mm), "features": False},
        "fit": {"method": "lin", "trim": 0.0, "confidence": 0.99},
        "solver": {"route": route},
    }


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
    support_plane: str | None  # the set's plane when it is one plane, else None
    load_plane: str | None
    reference_point: list | None  # m; None: the load set's centre (on its axis), known once meshed
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
    support_sel: list = field(default_factory=list)  # Selector: the clamped set
    load_sel: list = field(default_factory=list)  # Selector: the loaded set
    field_sel: list = field(default_factory=list)  # Selector: [field] region = "faces"
    load_tolerance: float | None = None  # m, planes of [load] (default: [support] tolerance)
    features: bool = True  # size fields at holes, fillets, thin walls, selected faces (meshing.refine)
    across: int = 3  # elements across the thinnest wall (a built-in box: over its section)
    around: int = 16  # elements around a hole's full circle
    accuracy: float | None = None  # relative compliance error to refine to (fea.accuracy)
    max_nodes: int = 300_000  # the memory limit: nodes of the largest mesh
    # [support] coupling: "rigid" clamps every node of the set (x, y, z);
    # "distributing" holds the set's work-conjugate (weighted mean) rigid
    # motion at zero and leaves it free to contract and warp (beam theory's clamp)
    support_coupling: str = "rigid"
    # [mesh] element: tet4 | tet10 (C3D4, C3D10) | hex8 | hex20 (C3D8, C3D20R)
    element: str = "tet10"
    raw: dict = field(default_factory=dict)

    @property
    def uses_cad_faces(self) -> bool:
        """True when a set names CAD faces (not only bounding-box planes)."""
        return any(cad_selectors(s) for s in (self.support_sel, self.load_sel, self.field_sel))

    @property
    def size_m(self) -> float:
        return self.size * self.scale

    def with_mesh(self, order: int | None = None, size: float | None = None) -> LinkJob:
        """A copy with another element order or size (checked as [mesh] is)."""
        job = copy.deepcopy(self)
        if order is not None:
            if order not in (1, 2) or isinstance(order, bool):
                raise ConfigError(f"{self.source}: mesh order {order!r}: 1 (C3D4) or 2 (C3D10)")
            job.order = int(order)
            kind = job.element[:3]
            job.element = (
                kind + ("4" if order == 1 else "10") if kind == "tet" else kind + ("8" if order == 1 else "20")
            )
        if size is not None:
            size = _num(size, f"{self.source}: mesh size", lo=0.0, lo_open=True)
            check_mesh_size(size, job.geometry, job.units, f"{self.source}: mesh size")
            job.size = size
        return job

    def closed_form_shape(self) -> tuple[float, str, list[float]] | None:
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
        if self.reference_point is not None and any(
            abs(a - b) > 1e-9 * L for a, b in zip(self.reference_point, [L, 0.0, 0.0])
        ):
            return None
        return L, sec[0], sec[1]


#: the keys of each section (a misspelt optional key is an error, not a silent default)
SECTIONS = {
    "geometry": ("step", "shape", "size", "length", "outer_diameter", "inner_diameter", "units"),
    "material": ("E", "nu", "density"),
    "support": (*KINDS, "tolerance", "coupling"),
    "load": (*KINDS, "tolerance", "reference_point", "coupling", "amplitudes"),
    "field": ("region", "size", *KINDS, "tolerance"),
    "mesh": MESH_KEYS,
    "fit": ("method", "trim", "confidence", "symmetrize", "pooled"),
    "solver": ("route", "timeout"),
    "approximation": ("section", "dims", "length"),
}
#: geometry keys of each built-in shape
SHAPE_KEYS = {
    "box": ("size",),
    "tube": ("length", "outer_diameter", "inner_diameter"),
    "rod": ("length", "outer_diameter"),
}
#: a link is 1 mm to 50 m long (beyond: the unit of the geometry is wrong)
PART_EXTENT_M = (1e-3, 50.0)


def _check_keys(data: dict, path: str) -> None:
    for section, keys in SECTIONS.items():
        if section not in data:
            continue
        tbl = data[section]
        if not isinstance(tbl, dict):
            raise ConfigError(f"{path}: [{section}] must be a table, got {tbl!r:.40}")
        unknown = sorted(set(tbl) - set(keys))
        if unknown:
            raise ConfigError(
                f"{path}: [{section}] unknown key(s) {', '.join(map(V.shown, unknown))}{_suggest(unknown[0], keys)}; "
                f"known: {', '.join(keys)}"
            )


def _part_extent(path: str, geometry: dict, units: str, scale: float) -> None:
    """A built-in part whose size is implausible for its declared unit: a warning."""
    dims = geometry.get("size") or [geometry.get("length", 0.0), geometry.get("outer_diameter", 0.0)]
    check_extent(max(dims) * scale, units, path)


def check_extent(extent_m: float, units: str, where: str) -> None:
    """Warn when a part's largest extent (m) is implausible for a link: the
    geometry's unit is most likely wrong (a STEP in metres declared mm)."""
    lo, hi = PART_EXTENT_M
    if extent_m < lo and units != "m":
        V.warn(
            f"{where}: the part is {extent_m:.3g} m across ([geometry] units = {units!r}); a link is "
            f'{lo * 1e3:g} mm to {hi:g} m: is the geometry in metres? set units = "m"',
            key=("extent", where),
        )
    elif extent_m > hi and units != "mm":
        V.warn(
            f"{where}: the part is {extent_m:.3g} m across ([geometry] units = {units!r}); a link is "
            f'{lo * 1e3:g} mm to {hi:g} m: is the geometry in millimetres? set units = "mm"',
            key=("extent", where),
        )


def parse_link(data: dict, path: str = "LINK.toml", base: Path | None = None) -> LinkJob:
    """Check a LINK.toml already parsed into a dict."""
    base = base or Path(".")
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: a LINK.toml document is a table of sections")
    for section in ("geometry", "material", "support", "load"):
        if section not in data or not isinstance(data[section], dict):
            raise ConfigError(f"{path}: section [{section}] is missing")
    known = set(SECTIONS)
    unknown = set(data) - known
    if unknown:
        first = sorted(unknown)[0]
        raise ConfigError(
            f"{path}: unknown section(s) {', '.join(map(V.shown, sorted(unknown)))}{_suggest(first, known)}; "
            f"known: {', '.join(sorted(known))}"
        )
    _check_keys(data, path)
    g = data["geometry"]
    units = _get(g, "units", "geometry", path, str, "mm")
    if "units" not in g:
        V.warn(
            f'{path}: [geometry] has no units: millimetres assumed (write units = "mm", or "m")',
            key=("link-units", str(path)),
        )
    if units not in UNITS:
        raise ConfigError(f"{path}: [geometry] units = {units!r}{_suggest(units, UNITS)}: one of {', '.join(UNITS)}")
    scale = UNITS[units]
    geometry: dict = {}
    if "step" in g and "shape" in g:
        raise ConfigError(f"{path}: [geometry] give either step (a CAD file) or shape, not both")
    if "step" in g:
        extra = sorted(set(g) - {"step", "units"})
        if extra:
            raise ConfigError(f"{path}: [geometry] {', '.join(extra)}: a CAD file (step) has no {extra[0]}")
        f = Path(_get(g, "step", "geometry", path, str))
        f = f if f.is_absolute() else (base / f)
        if not f.is_file():
            raise ConfigError(f"{path}: [geometry] step = {g['step']!r}: file not found ({f})")
        geometry["step"] = str(f.resolve())
    elif "shape" in g:
        shape = _choice(g["shape"], ("box", "tube", "rod"), "geometry", "shape", path)
        extra = sorted(set(g) - {"shape", "units"} - set(SHAPE_KEYS[shape]))
        if extra:
            raise ConfigError(
                f"{path}: [geometry] {', '.join(extra)}: not a key of shape = {shape!r} "
                f"(it takes {', '.join(SHAPE_KEYS[shape])})"
            )
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
        for key, v in geometry.items():
            vals = v if isinstance(v, list) else [v]
            if key != "shape" and max(vals) * scale > V.QUANTITIES["length"].limit:
                raise ConfigError(f"{path}: [geometry] {key} = {v!r} {units} is out of range for a link")
        _part_extent(path, geometry, units, scale)
    else:
        raise ConfigError(f'{path}: [geometry] needs step = "part.step" or shape = "box" | "tube" | "rod"')

    m = data["material"]
    E = _num(_get(m, "E", "material", path), f"{path}: [material] E", "E", lo=0.0, lo_open=True)
    nu = _num(_get(m, "nu", "material", path), f"{path}: [material] nu", lo=-1.0, hi=0.5, lo_open=True, hi_open=True)
    density = _num(
        _get(m, "density", "material", path, None, 7850.0),
        f"{path}: [material] density",
        "density",
        lo=0.0,
        lo_open=True,
    )

    ld = data["load"]
    sup_sel, tol = _selector_set(data["support"], "support", path)
    load_sel, ltol = _selector_set(ld, "load", path)
    sup = _one_plane(sup_sel)
    lplane = _one_plane(load_sel)
    same = {repr(s.key()[:2]) for s in sup_sel} & {repr(s.key()[:2]) for s in load_sel}
    if same:
        what = f"plane = {lplane!r}" if lplane and lplane == sup else f"selector {sorted(same)[0]}"
        raise ConfigError(
            f"{path}: [load] {what} is also the support plane: the load face must differ from the clamped face"
        )
    ref = None
    if "reference_point" in ld:
        ref = _get(ld, "reference_point", "load", path, list)
        if len(ref) != 3:
            raise ConfigError(f"{path}: [load] reference_point = {ref!r}: three coordinates")
        if max(abs(v) for v in ref) * scale > V.QUANTITIES["position"].limit:
            raise ConfigError(f"{path}: [load] reference_point = {ref!r} {units} is out of range")
    coupling = _choice(_get(ld, "coupling", "load", path, str, "rigid"), COUPLINGS, "load", "coupling", path)
    sup_coupling = _choice(
        _get(data["support"], "coupling", "support", path, str, "rigid"), COUPLINGS, "support", "coupling", path
    )
    amps = ld.get("amplitudes", "auto")
    if amps != "auto":
        if not isinstance(amps, list) or len(amps) != 6:
            raise ConfigError(
                f'{path}: [load] amplitudes = {amps!r}: "auto" or six positive '
                "numbers [Fx, Fy, Fz, Mx, My, Mz] in N and N m"
            )
        names = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")
        amps = [
            _num(a, f"{path}: [load] amplitudes {names[i]}", "force" if i < 3 else "moment", lo=0.0, lo_open=True)
            for i, a in enumerate(amps)
        ]
    fl = data.get("field", {})
    field_sel: list = []
    if any(k in fl for k in KINDS):
        field_sel, _ftol = _selector_set(fl, "field", path)
    region = _choice(
        _get(fl, "region", "field", path, str, "faces" if field_sel else "face"), REGIONS, "field", "region", path
    )
    if (region == "faces") != bool(field_sel):
        raise ConfigError(
            f'{path}: [field] region = "faces" goes with face selectors in [field] (face, cylinder, point, '
            f"box, group, plane){'' if field_sel else ': none given'}"
            + (f"; region = {region!r} takes none" if field_sel else "")
        )
    if region == "layer" and lplane is None:
        raise ConfigError(f'{path}: [field] region = "layer" needs a [load] plane (one bounding-box plane)')
    if "tolerance" in fl and not field_sel:
        raise ConfigError(f"{path}: [field] tolerance goes with face selectors in [field]")
    rsize = _get(fl, "size", "field", path, float, 0.0)
    if region in ("face", "faces"):
        if "size" in fl:
            raise ConfigError(f'{path}: [field] size is for region = "cube" or "layer", not {region!r}')
    else:
        _positive(rsize, "field", "size", path)
    me = data.get("mesh", {})
    mesher = _choice(_get(me, "mesher", "mesh", path, str, "gmsh"), ("gmsh", "tetgen"), "mesh", "mesher", path)
    element = _choice(_get(me, "element", "mesh", path, str, "tet10"), tuple(ELEMENT_NODES), "mesh", "element", path)
    e_order = 2 if ELEMENT_NODES[element] in (10, 20) else 1
    order = _choice(_get(me, "order", "mesh", path, int, e_order), (1, 2), "mesh", "order", path)
    if "element" in me and "order" in me and order != e_order:
        raise ConfigError(
            f"{path}: [mesh] order = {order} and element = {element!r} disagree (the element names its order; "
            "give one of them)"
        )
    if "element" not in me:  # the order names the tetrahedron
        element = "tet10" if order == 2 else "tet4"
    msh = str(geometry.get("step", "")).lower().endswith(".msh")
    if msh:  # a mesh already: used as it is
        given = sorted(set(me) & (set(MESH_KEYS) - {"mesher", "order", "max_nodes", "element"}))
        if given:
            raise ConfigError(
                f"{path}: [mesh] {', '.join(given)}: [geometry] step is a .msh, a mesh used as it is "
                "(only element or order, and max_nodes, apply)"
            )
        if _get(me, "mesher", "mesh", path, str, "gmsh") != "gmsh":
            raise ConfigError(f'{path}: [mesh] mesher: a .msh is read by Gmsh (mesher = "gmsh")')
        msize = 1.0  # not used: the mesh's own size is reported
    else:
        msize = _positive(_get(me, "size", "mesh", path, float), "mesh", "size", path)
        check_mesh_size(msize, geometry, units, f"{path}: [mesh] size")
    refine = _get(me, "refine", "mesh", path, float, None) if "refine" in me else None
    if refine is not None and not 0 < refine < 1:
        raise ConfigError(f"{path}: [mesh] refine = {refine!r}: a size factor in (0, 1)")
    rr = _get(me, "refine_radius", "mesh", path, float, None) if "refine_radius" in me else None
    if rr is not None:
        _positive(rr, "mesh", "refine_radius", path)
        if refine is None:
            raise ConfigError(f"{path}: [mesh] refine_radius needs refine (a size factor in (0, 1))")
    optimize = _choice(_get(me, "optimize", "mesh", path, str, "none"), ("none", "netgen"), "mesh", "optimize", path)
    structured = _get(me, "structured", "mesh", path, bool, False)
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
    if element.startswith("hex"):
        if mesher != "gmsh":
            raise ConfigError(f'{path}: [mesh] element = {element!r} needs mesher = "gmsh", not {mesher!r}')
        if refine is not None or optimize != "none":
            raise ConfigError(f'{path}: [mesh] element = {element!r} is structured: no refine, optimize = "none"')
    mk = check_mesh_keys(
        me,
        path,
        ConfigError,
        features=_get(me, "features", "mesh", path, bool, not msh),
        across=_get(me, "across", "mesh", path, int, default_across(geometry)),
        around=_get(me, "around", "mesh", path, int, AROUND),
        accuracy=_get(me, "accuracy", "mesh", path, float, None),
        max_nodes=_get(me, "max_nodes", "mesh", path, int, MAX_NODES),
    )
    fit = data.get("fit", {})
    method = _choice(_get(fit, "method", "fit", path, str, "lin"), FIT_METHODS, "fit", "method", path)
    trim = _get(fit, "trim", "fit", path, float, 0.0)
    if not 0 <= trim < 0.5:
        raise ConfigError(f"{path}: [fit] trim = {trim!r}: a fraction in [0, 0.5)")
    conf = _get(fit, "confidence", "fit", path, float, 0.99)
    if not 0 < conf < 1:
        raise ConfigError(f"{path}: [fit] confidence = {conf!r}: a level in (0, 1)")
    sym = _get(fit, "symmetrize", "fit", path, bool, False)
    pooled = _get(fit, "pooled", "fit", path, bool, True)
    so = data.get("solver", {})
    route = _choice(_get(so, "route", "solver", path, str, "auto"), ROUTES, "solver", "route", path)
    timeout = _num(
        _get(so, "timeout", "solver", path, None, 3600.0), f"{path}: [solver] timeout", "timeout", lo=0.0, lo_open=True
    )
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
        reference_point=None if ref is None else [v * scale for v in ref],
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
        load_tolerance=None if ltol is None else ltol * scale,
        support_sel=sup_sel,
        load_sel=load_sel,
        field_sel=field_sel,
        ccx_timeout=timeout,
        approximation=approx,
        pooled=pooled,
        structured=structured,
        across_factor=across,
        support_coupling=sup_coupling,
        element=element,
        raw=data,
        **mk,
    )


def _selector_set(tbl: dict, section: str, path: str) -> tuple[list[Selector], float | None]:
    """The checked selectors of a section (at least one) and its tolerance."""
    try:
        sels, tol = parse_set(tbl, section, path)
    except SelectorError as exc:
        raise ConfigError(str(exc)) from None
    if not sels:
        raise ConfigError(
            f"{path}: [{section}] selects no face: give plane, face, cylinder, point, box or group "
            "(stiffkit link --list-faces PART lists a CAD part's faces)"
        )
    return sels, tol


def _one_plane(sels: list[Selector]) -> str | None:
    """The plane of a set that is exactly one bounding-box plane, else None."""
    planes = planes_of(sels)
    return planes[0] if len(sels) == 1 and planes else None


def part_dims(geometry: dict) -> list[float] | None:
    """The bounding-box sizes (geometry units) of a built-in shape, None for CAD."""
    if "size" in geometry:
        return list(geometry["size"])
    if "length" in geometry:
        d = geometry["outer_diameter"]
        return [geometry["length"], d, d]
    return None


def check_mesh_size(size: float, geometry: dict, units: str, name: str, dims: list[float] | None = None) -> None:
    """An element size larger than the whole part is an error; larger than
    its smallest side (less than one element across) a warning. ``dims``:
    the part's bounding box (geometry units) when it is not a built-in shape."""
    dims = dims if dims is not None else part_dims(geometry)
    if not dims:
        return
    wall = None
    if geometry.get("shape") == "tube":
        wall = (geometry["outer_diameter"] - geometry["inner_diameter"]) / 2
    if size > max(dims):
        raise ConfigError(
            f"{name} = {size:g} {units} is larger than the whole part ({' x '.join(f'{d:g}' for d in dims)} {units}); "
            "give an element size a fraction of its smallest side"
        )
    small = min(dims + ([wall] if wall else []))
    if size > small:
        V.warn(
            f"{name} = {size:g} {units} is larger than the part's smallest "
            f"{'wall' if wall and small == wall else 'side'} ({small:g} {units}): less than one element "
            "across, the compliance will be far off",
            key=("mesh size", name),
        )


def load_link(path: Path | str) -> LinkJob:
    """Read and check LINK.toml (see the module docstring)."""
    if not isinstance(path, (str, Path)):
        raise ConfigError(f"load_link takes the path of a LINK.toml, got {type(path).__name__}")
    p = Path(path)
    data = read_toml(p, "LINK.toml", error=ConfigError)
    return parse_link(data, str(p), p.resolve().parent)
