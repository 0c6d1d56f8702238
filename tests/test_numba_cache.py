"""numba's on-disk cache is keyed on the kernels a module calls, not on its own file only.

Before: a kernel whose callee lived in another file kept its cached machine code
after only the callee's file changed (``plan/_graphwalk.py`` calling
``plan/_treap.py``, ``smooth/abam.py`` inlining ``smooth/spans.py``), so a
checkout ran the old callee inside the new caller. ``polishpath._numba_cache``
stamps each file's cache with the hash of its kernel closure.
"""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import polishpath
from polishpath import _numba_cache as nc

SRC = Path(polishpath.__file__).resolve().parent


def _write_pkg(root: Path, callee_value: int) -> None:
    pkg = root / "ppk"
    pkg.mkdir(exist_ok=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "plain.py").write_text("X = 1\n")
    (pkg / "b.py").write_text(textwrap.dedent(f"""
        import numba

        @numba.njit(cache=True)
        def g():
            return {callee_value}
        """))
    (pkg / "a.py").write_text(textwrap.dedent("""
        import numba
        from . import plain
        from .b import g

        @numba.njit(cache=True)
        def f():
            return g() + 10
        """))


_RUNNER = textwrap.dedent("""
    import sys
    from pathlib import Path
    root = Path(sys.argv[1]).resolve()
    sys.path.insert(0, str(root))
    if sys.argv[2] == "closure":
        from polishpath import _numba_cache as nc

        class Locator(nc.ClosureStampMixin, nc.numba_locator("InTreeCacheLocator")):
            pass
        Locator.root = root / "ppk"
        Locator.package = "ppk"
        nc.register((Locator,))
    from ppk.a import f
    print(f())
""")


def _run(root: Path, mode: str) -> int:
    out = subprocess.run([sys.executable, "-c", _RUNNER, str(root), mode], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr
    return int(out.stdout.split()[-1])


def test_callee_edit_reaches_a_cached_caller(tmp_path):
    # numba's own stamp: the caller's cache survives an edit of the callee (the bug this guards against)
    plain = tmp_path / "numba_only"
    plain.mkdir()
    _write_pkg(plain, 1)
    assert _run(plain, "numba") == 11
    _write_pkg(plain, 2)
    stale = _run(plain, "numba")
    # with the closure stamp the caller is compiled again with the new callee
    fixed = tmp_path / "closure"
    fixed.mkdir()
    _write_pkg(fixed, 1)
    assert _run(fixed, "closure") == 11
    assert _run(fixed, "closure") == 11  # from the cache
    _write_pkg(fixed, 2)
    assert _run(fixed, "closure") == 12
    # if numba itself ever keys on callees, this test still holds; say so rather than fail
    if stale == 12:
        pytest.skip("this numba already recompiles a caller whose callee changed; the closure stamp is redundant")
    assert stale == 11


def test_closure_follows_kernels_and_packages_not_plain_modules(tmp_path):
    _write_pkg(tmp_path, 1)
    root = tmp_path / "ppk"
    got = nc.kernel_closure(root / "a.py", root, "ppk")
    assert [p.name for p in got] == ["a.py", "b.py"]
    before = nc.closure_digest(root / "a.py", root, "ppk")
    (root / "plain.py").write_text("X = 2\n")  # not a kernel file: no recompile
    assert nc.closure_digest(root / "a.py", root, "ppk") == before
    (root / "b.py").write_text((root / "b.py").read_text().replace("return 1", "return 3"))
    assert nc.closure_digest(root / "a.py", root, "ppk") != before


def test_the_walks_closure_holds_the_treap():
    names = {str(p.relative_to(SRC)) for p in nc.kernel_closure(SRC / "plan" / "_graphwalk.py")}
    assert {"plan/_graphwalk.py", "plan/_treap.py", "plan/_steps.py"} <= names
    names = {str(p.relative_to(SRC)) for p in nc.kernel_closure(SRC / "smooth" / "abam.py")}
    assert "smooth/spans.py" in names


def test_registered_first_for_the_package_only():
    import numba.core.caching as caching

    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
    assert impl._locator_classes[:3] == [nc.PackageUserProvidedLocator, nc.PackageInTreeLocator,
                                         nc.PackageUserWideLocator]

    def outside():
        return 1

    assert nc.PackageInTreeLocator.from_function(outside, __file__) is None


_CACHED = re.compile(r"cache\s*=\s*True")
_IMPORTS_IT = re.compile(r"^[ \t]*(?:from[ \t]+(?:\.+|polishpath)[ \t]+import[ \t]+_numba_cache|"
                         r"import[ \t]+polishpath\._numba_cache)", re.M)


def test_every_cached_kernel_file_imports_the_closure_stamp():
    """Architecture rule: a file with ``cache=True`` kernels imports ``_numba_cache`` before its first one."""
    breaches = []
    for f in sorted(SRC.rglob("*.py")):
        text = f.read_text(encoding="utf-8")
        first = _CACHED.search(text)
        if first is None or f.name == "_numba_cache.py":
            continue
        imp = _IMPORTS_IT.search(text)
        if imp is None or imp.start() > first.start():
            breaches.append(str(f.relative_to(SRC)))
    assert not breaches, (
        f"{breaches} cache numba kernels without polishpath._numba_cache: their caches would outlive an edit of a "
        "kernel they call in another file. Fix: add `from .. import _numba_cache  # noqa: F401` (as many dots as "
        "the file is deep) after `import numba`, before the first @numba.njit(cache=True).")
