"""The [mesh] keys of the feature refinement and the accuracy loop (issue 18):
their checks, the default memory limit and its memory model. The values are
read by :func:`stiffkit.fea.config.parse_link`; the checks raise its
ConfigError (passed in, so this module does not import config)."""

from __future__ import annotations

#: the keys of [mesh]
MESH_KEYS = (
    "mesher",
    "order",
    "size",
    "refine",
    "refine_radius",
    "optimize",
    "structured",
    "across_factor",
    "features",
    "across",
    "around",
    "accuracy",
    "max_nodes",
    "element",
)
#: the default memory limit: nodes of the largest mesh (about 8 GB on the
#: matrix route: 109,531 nodes took 1.7 GB, 237,423 nodes 4.6 GB)
MAX_NODES = 300_000
#: ``accuracy``: the relative error a user may ask for
ACCURACY_RANGE = (1e-5, 0.2)


def node_memory_gb(nodes: int) -> float:
    """Peak memory of a matrix-route run of this many C3D10 nodes, GB (the
    sweep's model fitted to the paper's beam: 1.7 GB at 109,531 nodes)."""
    return (100.0 + 1.25 * 465.0 * (nodes / 40084) ** 1.28) / 1024


def check_mesh_keys(me: dict, path: str, error: type[Exception], **v: object) -> dict:
    """Check the values read from [mesh] (features, across, around, accuracy
    or None, max_nodes); returns them as LinkJob fields."""

    def at_least(key: str, lo: int) -> None:
        if v[key] < lo:
            raise error(f"{path}: [mesh] {key} = {v[key]!r}: an integer >= {lo}")

    for key in ("across", "around"):
        if key in me and not v["features"]:
            raise error(f"{path}: [mesh] {key} needs features = true (it sets the feature refinement)")
    at_least("across", 1)
    at_least("around", 3)
    at_least("max_nodes", 1000)
    if v["across"] > 100 or v["around"] > 1000:
        raise error(
            f"{path}: [mesh] across = {v['across']}, around = {v['around']}: at most 100 across and 1000 around "
            "(more than any mesh can hold)"
        )
    acc = v["accuracy"]
    lo, hi = ACCURACY_RANGE
    if acc is not None and not lo <= acc <= hi:
        raise error(f"{path}: [mesh] accuracy = {acc!r}: a relative error in [{lo:g}, {hi:g}] (0.001 is 0.1 %)")
    return dict(v)
