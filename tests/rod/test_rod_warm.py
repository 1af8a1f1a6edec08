"""The engine's numba caches are cleared when any of its sources changed (a kernel's cache is keyed on its own file
only, so a caller would otherwise load a stale callee), and kept when none did."""

from dresspack_gym.rod.warm import clear_stale_caches, sources_digest


def test_caches_are_cleared_when_a_source_changes_and_kept_otherwise(tmp_path):
    (tmp_path / "contact").mkdir()
    (tmp_path / "kernel.py").write_text("x = 1\n")
    (tmp_path / "contact" / "callee.py").write_text("y = 2\n")
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    cached = [cache / "kernel.f-1.py311.nbi", cache / "kernel.f-1.py311.1.nbc"]

    def write_caches():
        for path in cached:
            path.write_bytes(b"compiled")

    write_caches()
    assert clear_stale_caches(tmp_path)  # no digest yet: whatever is cached may be stale
    assert not any(path.exists() for path in cached)
    write_caches()
    assert not clear_stale_caches(tmp_path)  # the same sources: the caches stay
    assert all(path.exists() for path in cached)
    before = sources_digest(tmp_path)
    (tmp_path / "contact" / "callee.py").write_text("y = 3\n")  # a callee in another file
    assert sources_digest(tmp_path) != before
    assert clear_stale_caches(tmp_path)
    assert not any(path.exists() for path in cached)
