"""numba's on-disk cache, keyed on every kernel a module's kernels can call.

numba (``@numba.njit(cache=True)``) keys a function's cached machine code on its
**own** source file only. A kernel that calls a kernel of another file (the
walks call the treap's, the smoothing stage's ``abam`` inlines ``spans``) keeps
its stale machine code after only the callee's file changed: a `git pull` or an
edit in a checkout then runs the old callee inside the new caller, silently.

Every module with cached kernels imports this module before its first
``@numba.njit(cache=True)`` (``tests/test_numba_cache.py`` guards that rule). It
puts two cache locators in front of numba's own, for the package's files only:
the same places as numba's in-tree and user-wide caches, but their source stamp
is a hash of the file **and** every kernel file it imports from the package,
directly or through other modules (its import closure; only the files that use
numba are hashed, so an edit of ``types.py`` recompiles nothing). Editing
``_treap.py`` thus recompiles the treap and the walks that import it, not the
flattening stage.

Written by hand because numba has no option for it: its locators are the
documented extension point (``numba.core.caching``), the import closure is
read from the source text with a regular expression (not imported, not
executed), once per process.
"""

from __future__ import annotations

import functools
import hashlib
import re
from pathlib import Path

import numba.core.caching as _caching

#: The package's folder: only functions defined under it use these locators.
PACKAGE_DIR = Path(__file__).resolve().parent
PACKAGE = "polishpath"

# `from .x import a, b`, `from ..y.z import (a,\n b)`, `from polishpath.x import a`, `import polishpath.x`
_FROM = re.compile(r"^[ \t]*from[ \t]+(\.+[\w.]*|polishpath(?:\.[\w.]+)?)[ \t]+import[ \t]+(\([^)]*\)|[^\n#]+)", re.M)
_IMPORT = re.compile(r"^[ \t]*import[ \t]+(polishpath(?:\.[\w.]+)?)", re.M)


def _module_file(dotted: str, root: Path, package: str) -> Path | None:
    """The source file of module ``dotted`` (``polishpath.plan._treap``) under ``root``, or None."""
    parts = dotted.split(".")
    if parts[0] != package:
        return None
    base = root.joinpath(*parts[1:])
    for cand in (base.with_suffix(".py"), base / "__init__.py"):
        if cand.is_file():
            return cand
    return None


def _dotted_name(path: Path, root: Path, package: str) -> str:
    rel = path.relative_to(root).with_suffix("")
    parts = [package, *rel.parts]
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imported_package_files(path: Path, root: Path = PACKAGE_DIR, package: str = PACKAGE) -> frozenset[Path]:
    """Files of the package that ``path``'s source imports (one level, not transitive).

    Parameters
    ----------
    path : Path
        A source file under ``root``.
    root, package : Path, str
        The package's folder and its import name.

    Returns
    -------
    frozenset of Path
        Each module named in a ``from ... import`` or ``import`` of the package
        (relative or absolute), and each name imported from a package that is
        itself a submodule (``from . import _treap``).
    """
    text = path.read_text(encoding="utf-8", errors="replace")
    me = _dotted_name(path, root, package)
    here = me if path.name == "__init__.py" else me.rpartition(".")[0]
    found: set[Path] = set()
    for mod, names in _FROM.findall(text):
        if mod.startswith("."):
            dots = len(mod) - len(mod.lstrip("."))
            base = here.split(".")
            if dots - 1 > len(base) - 1:
                continue
            base = base[: len(base) - (dots - 1)]
            rest = mod[dots:]
            full = ".".join(base + ([rest] if rest else []))
        else:
            full = mod
        f = _module_file(full, root, package)
        if f is not None:
            found.add(f)
        for name in re.findall(r"\w+", re.sub(r"\bas\s+\w+", "", names)):
            sub = _module_file(f"{full}.{name}", root, package)
            if sub is not None:
                found.add(sub)
    for mod in _IMPORT.findall(text):
        f = _module_file(mod, root, package)
        if f is not None:
            found.add(f)
    found.discard(path)
    return frozenset(found)


# one read of each file per process for the stamps of all kernels (their closures overlap); the tests call
# the uncached functions on files they edit
_imports_cached = functools.lru_cache(maxsize=None)(imported_package_files)


_USES_NUMBA = re.compile(rb"^[ \t]*(?:import[ \t]+numba|from[ \t]+numba[ \t.])", re.M)


def uses_numba(path: Path) -> bool:
    """Whether the file imports numba (at any indentation: kernels compiled on first use count)."""
    return _USES_NUMBA.search(Path(path).read_bytes()) is not None


_uses_numba_cached = functools.lru_cache(maxsize=None)(uses_numba)


def kernel_closure(path: Path, root: Path = PACKAGE_DIR, package: str = PACKAGE, *, _cached: bool = False) -> list[Path]:
    """``path`` and every file of the package whose kernels ``path``'s kernels can call.

    A kernel calls only compiled functions, so the closure follows imports from
    ``path`` through files that use numba and through packages' ``__init__.py``
    (which re-export them), not through ordinary modules (``types.py``, the
    pipeline): editing those recompiles nothing.

    Returns
    -------
    list of Path
        Sorted, resolved; ``path`` itself always included.
    """
    imports, numba_in = (_imports_cached, _uses_numba_cached) if _cached else (imported_package_files, uses_numba)
    path = Path(path).resolve()
    root = Path(root).resolve()  # the imported files are joined onto it: resolved too
    seen = {path}
    todo = [path]
    while todo:
        for f in imports(todo.pop(), root, package):
            if f in seen:
                continue
            if f.name == "__init__.py" or numba_in(f):
                seen.add(f)
                todo.append(f)
    return sorted(f for f in seen if f == path or numba_in(f))


def closure_digest(py_file: Path, root: Path = PACKAGE_DIR, package: str = PACKAGE, *, _cached: bool = False) -> bytes:
    """A SHA-256 over :func:`kernel_closure`'s files: their paths (relative to ``root``) and contents."""
    h = hashlib.sha256()
    root = Path(root).resolve()
    for f in kernel_closure(Path(py_file), root, package, _cached=_cached):
        h.update(str(f.relative_to(root)).encode())
        h.update(b"\0")
        h.update(f.read_bytes())
        h.update(b"\0")
    return h.digest()


@functools.lru_cache(maxsize=None)
def _closure_stamp(py_file: str, root: str, package: str) -> bytes:
    # once per file and process, like numba's own stamp
    return closure_digest(Path(py_file), Path(root), package, _cached=True)


class ClosureStampMixin:
    """A locator for one package's own files whose source stamp covers the kernels they import.

    Subclass it before one of numba's locators and set ``root`` and ``package``.
    """

    root: Path = PACKAGE_DIR
    package: str = PACKAGE

    @classmethod
    def from_function(cls, py_func, py_file):
        try:
            Path(py_file).resolve().relative_to(cls.root)
        except (ValueError, OSError):
            return None
        return super().from_function(py_func, py_file)

    def get_source_stamp(self):
        return _closure_stamp(str(Path(self._py_file).resolve()), str(self.root), self.package)


def numba_locator(name: str):
    """numba's locator class ``name`` (``InTreeCacheLocator``; numba < 0.61 names it with a leading ``_``)."""
    return getattr(_caching, name, None) or getattr(_caching, "_" + name)


class PackageUserProvidedLocator(ClosureStampMixin, numba_locator("UserProvidedCacheLocator")):
    """The user's ``NUMBA_CACHE_DIR`` (when set), stamped by the kernel closure."""


class PackageInTreeLocator(ClosureStampMixin, numba_locator("InTreeCacheLocator")):
    """numba's in-tree cache (``__pycache__`` beside the source), stamped by the kernel closure."""


class PackageUserWideLocator(ClosureStampMixin, numba_locator("UserWideCacheLocator")):
    """numba's user-wide cache (for a read-only install), stamped by the kernel closure."""


def register(locators=(PackageUserProvidedLocator, PackageInTreeLocator, PackageUserWideLocator)) -> None:
    """Put ``locators`` first in numba's list (idempotent).

    The same order as numba's own: a user's ``NUMBA_CACHE_DIR`` first, then the
    tree, then the user-wide folder. ``NUMBA_CACHE_LOCATOR_CLASSES``, when set,
    replaces numba's list altogether and these with it.
    """
    impl = getattr(_caching, "CacheImpl", None) or _caching._CacheImpl
    ours = list(locators)
    if impl._locator_classes[: len(ours)] != ours:
        impl._locator_classes = ours + [c for c in impl._locator_classes if c not in ours]


register()
