"""The shape of the source tree: folders are import paths, the stages form
a layered graph without cycles, only bindings/ calls the f2py extensions,
the error tables of Fortran, C and Python agree, and every equation the
README cites is mapped to a routine that exists (docs/ARCHITECTURE.md)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: folder -> installed package; the order is the layering, bottom first: a
#: folder may import only from folders before it (and from itself)
LAYERS = [
    ("stiffkit", "stiffkit"),  # errors, version (the package face imports the stages lazily below)
    ("bindings", "stiffkit._core"),
    ("io", "stiffkit.io"),
    ("meshing", "stiffkit.meshing"),
    ("field", "stiffkit.field"),
    ("fea", "stiffkit.fea"),
    ("sweep", "stiffkit.sweep"),
    ("robot", "stiffkit.robot"),
    ("springs", "stiffkit.springs"),
    ("calib", "stiffkit.calib"),
    ("cli", "stiffkit.cli"),
]
PACKAGES = dict(LAYERS)
#: modules of the package face that every stage may import (they import nothing of stiffkit)
ROOT_LEAVES = {"stiffkit.errors", "stiffkit.version"}


def _modules() -> dict[str, Path]:
    out = {}
    for folder, pkg in LAYERS:
        for f in sorted((ROOT / folder).glob("*.py")):
            name = pkg if f.stem == "__init__" else f"{pkg}.{f.stem}"
            out[name] = f
    return out


def _imports(name: str, path: Path) -> set[str]:
    """Absolute names of every stiffkit module imported anywhere in the file
    (function-level imports included; imports for type checkers only, under
    ``if TYPE_CHECKING:``, are not run and are left out)."""
    tree = ast.parse(path.read_text(), str(path))
    pkg = name if path.stem == "__init__" else name.rpartition(".")[0]
    typing_only = {
        id(n)
        for blk in ast.walk(tree)
        if isinstance(blk, ast.If) and isinstance(blk.test, ast.Name) and blk.test.id == "TYPE_CHECKING"
        for stmt in blk.body
        for n in ast.walk(stmt)
    }
    found = set()
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".")
                base = base[: len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod.startswith("stiffkit"):
                found.add(mod)
                for alias in node.names:
                    found.add(f"{mod}.{alias.name}")
        elif isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.startswith("stiffkit")}
    return found


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    graph = {}
    for name, path in mods.items():
        deps = set()
        for imp in _imports(name, path):
            # the longest known module name that the import refers to
            while imp and imp not in mods:
                imp = imp.rpartition(".")[0]
            # a package's __init__ re-exporting its own modules is not a dependency of logic
            if imp and imp != name and not (path.stem == "__init__" and imp.startswith(name + ".")):
                deps.add(imp)
        graph[name] = deps
    return graph


def _stage(module: str) -> str:
    best = ""
    for _folder, pkg in LAYERS:
        if (module == pkg or module.startswith(pkg + ".")) and len(pkg) > len(best):
            best = pkg
    return best


def test_folders_install_as_their_import_path():
    for folder, pkg in LAYERS:
        build = (ROOT / folder / "meson.build").read_text()
        subdir = "/".join(pkg.split(".")).replace("stiffkit/_core", "stiffkit/_core")
        assert f"subdir: '{subdir}'" in build, f"{folder}/meson.build must install into {subdir}"
        listed = set(re.findall(r"'([\w]+\.py)'", build))
        present = {f.name for f in (ROOT / folder).glob("*.py")}
        assert listed == present, f"{folder}/meson.build lists {sorted(listed ^ present)} wrongly"


def test_no_import_cycle_between_modules():
    graph = _graph()
    index, low, stack, on, cycles = {}, {}, [], set(), []
    counter = [0]

    def strong(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in graph:
        if v not in index:
            strong(v)
    assert not cycles, f"import cycles: {cycles}"


def test_stages_import_only_the_layers_below():
    order = {pkg: i for i, (_f, pkg) in enumerate(LAYERS)}
    bad = []
    for mod, deps in _graph().items():
        me = _stage(mod)
        for d in deps:
            if d in ROOT_LEAVES or _stage(d) == me:
                continue
            if me == "stiffkit":  # the package face re-exports the stages
                continue
            if order[_stage(d)] >= order[me]:
                bad.append(f"{mod} -> {d}")
    assert not bad, "imports against the layering: " + "; ".join(sorted(bad))


def _extensions() -> list[str]:
    """The f2py extensions: one per signature file bindings/_name.pyf."""
    return sorted(p.stem for p in (ROOT / "bindings").glob("_*.pyf"))


def test_only_bindings_call_the_extensions():
    names = "|".join(e.lstrip("_") for e in _extensions())
    bad = []
    for name, path in _modules().items():
        if name.startswith("stiffkit._core"):
            continue
        text = path.read_text()
        if re.search(rf"\b_({names})\.sk_", text) or re.search(rf"import _({names})\b", text):
            bad.append(name)
    assert not bad, f"modules calling an f2py extension directly: {bad}"


def test_every_signature_file_is_one_extension():
    """bindings/meson.build builds one extension per .pyf, each .pyf names
    its own module, bindings/__init__.py lists them all, every one imports,
    and f2py's fortranobject.c is compiled once (a static library linked
    into each extension), not once per extension."""
    import importlib

    exts = _extensions()
    assert {"_calib", "_design", "_field", "_sparse", "_springs", "_tree"} <= set(exts)
    build = (ROOT / "bindings" / "meson.build").read_text()
    listed = re.search(r"f2py_exts = \[([^\]]*)\]", build)
    assert listed and sorted(re.findall(r"'(\w+)'", listed.group(1))) == exts
    doc = importlib.import_module("stiffkit._core").__doc__
    for ext in exts:
        pyf = (ROOT / "bindings" / f"{ext}.pyf").read_text()
        assert re.findall(r"^python module (\w+)", pyf, flags=re.M) == [ext], f"{ext}.pyf names another module"
        assert f"``{ext}``" in doc, f"bindings/__init__.py's docstring misses {ext}"
        mod = importlib.import_module(f"stiffkit._core.{ext}")
        routines = set(re.findall(r"^\s*subroutine (sk_\w+)", pyf, flags=re.M))
        assert routines and routines <= set(dir(mod)), f"{ext}: {sorted(routines - set(dir(mod)))} not built"
    assert build.count("fortranobject_c") == 2, "fortranobject.c: defined once, compiled once"
    assert re.search(r"static_library\('_fortranobject', fortranobject_c", build)
    assert re.search(r"extension_module\(ext, \[src\],\s*dependencies: \[[^\]]*fortranobject_dep", build)


def _fortran_codes() -> dict[str, int]:
    text = (ROOT / "core" / "sk_errors.f90").read_text()
    return {
        m.group(1): int(m.group(2)) for m in re.finditer(r"::\s*sk_(?:ok|err_(\w+))\s*=\s*(\d+)", text) if m.group(1)
    }


def test_error_tables_agree():
    from stiffkit._core.errors import INFO, NAMES

    fortran = _fortran_codes()
    assert fortran, "no codes found in core/sk_errors.f90"
    assert {NAMES[c]: c for c in INFO} == fortran, "Python INFO/NAMES differ from core/sk_errors.f90"
    ctext = (ROOT / "core" / "sk_status.h").read_text()
    for name, code in re.findall(r"#define SK_ERR_(\w+) (\d+)", ctext):
        assert fortran.get(name.lower()) == int(code), f"sk_status.h SK_ERR_{name} = {code} differs from Fortran"
    assert re.search(r"#define SK_OK 0\b", ctext)
    # the C files take their codes from that header, none defines its own
    for path in sorted((ROOT / "core").glob("*.c")):
        assert not re.search(r"#define SK_(OK|ERR_\w+) ", path.read_text()), f"{path.name} defines a status code"


def test_error_check_maps_every_code():
    from stiffkit._core.errors import INFO, check
    from stiffkit.errors import StiffkitError

    for code, (cls, text) in INFO.items():
        with pytest.raises(cls, match=r"routine_x: ") as exc:
            check(code, "routine_x")
        assert exc.value.info == code and "info=" not in str(exc.value) and text in str(exc.value)
    with pytest.raises(StiffkitError, match="unknown status 99"):
        check(99, "routine_x")


def _equation_rows() -> list[tuple[str, str, str]]:
    text = (ROOT / "docs" / "ARCHITECTURE.md").read_text()
    rows = []
    for line in text.splitlines():
        m = re.match(r"\|\s*([^|]+?)\s*\|\s*([^|]+?)\s*\|\s*`([\w/.]+):(\w+)`", line)
        if m:
            rows.append((m.group(1), m.group(2), m.group(3) + ":" + m.group(4)))
    return rows


def test_equation_table_routines_exist():
    rows = _equation_rows()
    assert len(rows) >= 20, "docs/ARCHITECTURE.md's equation table is missing or short"
    for paper, eq, where in rows:
        path, routine = where.split(":")
        text = (ROOT / path).read_text()
        pattern = (
            rf"(subroutine|function)\s+{routine}\b"
            if path.endswith(".f90")
            else rf"(def|class)\s+{routine}\b"
            if path.endswith(".py")
            else rf"\b{routine}\s*\("
        )
        assert re.search(pattern, text, re.IGNORECASE), f"{paper} {eq}: {routine} not found in {path}"


def test_readme_equations_are_in_the_table():
    readme = (ROOT / "README.md").read_text()
    cited = set()
    for m in re.finditer(r"\beqs?\.\s*([\d\-, and]+)", readme):
        for part in re.split(r",|and", m.group(1)):
            part = part.strip()
            if not part:
                continue
            if "-" in part:
                a, b = part.split("-")[:2]
                if a.isdigit() and b.isdigit():
                    cited |= {str(k) for k in range(int(a), int(b) + 1)}
            elif part.isdigit():
                cited.add(part)
    table = set()
    for _paper, eq, _where in _equation_rows():
        for m in re.finditer(r"\d+(?:-\d+)?", eq):
            if "-" in m.group(0):
                a, b = m.group(0).split("-")
                table |= {str(k) for k in range(int(a), int(b) + 1)}
            else:
                table.add(m.group(0))
    missing = sorted(cited - table, key=int)
    assert not missing, f"equations cited in README.md without a row in docs/ARCHITECTURE.md: {missing}"


def test_repo_stands_alone():
    bad = []
    for path in ROOT.rglob("*"):
        if any(p in path.parts for p in (".git", ".venv", "build", "__pycache__", ".hypothesis")):
            continue
        if (
            path.is_file()
            and path.suffix in (".py", ".md", ".f90", ".c", ".pyf", ".build", ".toml", "")
            and path.name != "test_architecture.py"
        ):
            try:
                text = path.read_text()
            except (UnicodeDecodeError, OSError):
                continue
            if "../shared" in text or "TOOLCHAIN_NOTES" in text or "shared/spec" in text:
                bad.append(str(path.relative_to(ROOT)))
    assert not bad, f"files pointing outside the repository: {bad}"


def _named_codes(path: str, prefix: str) -> dict[str, int]:
    """``prefix_name = N`` integer parameters of a core file, upper-cased."""
    text = (ROOT / path).read_text()
    return {m[0].upper(): int(m[1]) for m in re.findall(rf"\b({prefix}_[a-z0-9]+)\s*=\s*(\d+)\b", text)}


def test_integer_codes_shared_with_the_core_agree():
    """The integer codes Python hands the core (law types of the tree model,
    spring types of the chain) are the core's own named constants."""
    from stiffkit.robot import catalogue, model, tree_model

    laws = _named_codes("core/sk_laws.f90", "law")  # defined there, re-exported by sk_tree
    laws.pop("LAW_NSLOT", None)  # a function result, not a code
    # the catalogue of kinds holds Python's codes (robot/catalogue.py); the tree model takes them from it
    py_laws = {k: v for k, v in vars(tree_model).items() if k.startswith("LAW_") and isinstance(v, int)}
    assert laws and catalogue.LAWS == laws and py_laws.items() <= laws.items()
    springs = _named_codes("core/sk_chain.f90", "spring")
    py_springs = {k: v for k, v in vars(model).items() if k.startswith("SPRING_") and isinstance(v, int)}
    assert springs and py_springs == springs


def test_folder_table_follows_the_layering():
    """docs/ARCHITECTURE.md lists the folders in the order of LAYERS, so
    its sentence "imports only from the folders above it" is true."""
    text = (ROOT / "docs" / "ARCHITECTURE.md").read_text()
    rows = re.findall(r"^\| `([a-z_]+)/` \|", text, flags=re.M)
    # the package face (errors, version) may be imported by every folder: its
    # row stands beside bindings/, the rest follows LAYERS exactly
    order = [r for r in rows if r in PACKAGES and r != "stiffkit"]
    assert order == [folder for folder, _ in LAYERS if folder != "stiffkit"]
