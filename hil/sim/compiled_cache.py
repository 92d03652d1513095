"""Keep numba's on-disk cache of the engine consistent with the engine's sources.

numba keys a cached function on the timestamp of its own file only, not on the functions and
global constants it takes from other modules, so editing ``electrical.py`` or ``layout.py`` could
leave a stale compiled ``kernel.run_drive``. On import this drops the package's cached objects
whenever the digest of the engine sources differs from the one recorded beside the cache.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

ENGINE_SOURCES = ("compiled_cache.py", "electrical.py", "firmware.py", "kernel.py", "layout.py")


def refresh_cache(package_dir: Path = Path(__file__).parent) -> bool:
    """Delete stale ``*.nbi``/``*.nbc`` files; return True if it did. Never raises on I/O."""
    digest = hashlib.sha256()
    for name in ENGINE_SOURCES:
        digest.update((package_dir / name).read_bytes())
    cache_dir = package_dir / "__pycache__"
    stamp = cache_dir / "engine-sources.sha256"
    try:
        if stamp.read_text() == digest.hexdigest():
            return False
    except OSError:
        pass
    try:
        cache_dir.mkdir(exist_ok=True)
        for pattern in ("*.nbi", "*.nbc"):
            for stale in cache_dir.glob(pattern):
                stale.unlink(missing_ok=True)
        stamp.write_text(digest.hexdigest())
    except OSError:
        return False
    return True


refresh_cache()
