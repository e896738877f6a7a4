"""PyBullet, imported and connected without its banners on stdout.

``import pybullet`` prints its build time (stderr) and every ``connect`` prints ``argv[0]=`` (stdout) from
C code straight to the file descriptors, which would interleave with ``navstack``'s own output (and with anything piped
from it).  Both go through :func:`quiet_stdout`, which points both at ``/dev/null`` for the duration.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator


@contextlib.contextmanager
def _quiet_fd(stream) -> Iterator[None]:
    try:
        fd = stream.fileno()
    except (AttributeError, OSError, ValueError):  # no real file behind it (e.g. captured): nothing to do
        yield
        return
    stream.flush()
    saved = os.dup(fd)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), fd)
            try:
                yield
            finally:
                stream.flush()
                os.dup2(saved, fd)
    finally:
        os.close(saved)


@contextlib.contextmanager
def quiet_stdout() -> Iterator[None]:
    """Silence file descriptors 1 and 2 (C-level prints included) inside the block.

    Python exceptions still propagate; only what is *printed* meanwhile is dropped.
    """
    with _quiet_fd(sys.stdout), _quiet_fd(sys.stderr):
        yield


with quiet_stdout():
    import pybullet  # noqa: E402

from pybullet_utils.bullet_client import BulletClient  # noqa: E402


def direct_client() -> BulletClient:
    """A new headless (DIRECT) ``BulletClient``, without the connect banner."""
    with quiet_stdout():
        return BulletClient(connection_mode=pybullet.DIRECT)


__all__ = ["BulletClient", "direct_client", "pybullet", "quiet_stdout"]
