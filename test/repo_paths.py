"""Where the tests find the checkout and the read-only shared material, from any folder of test/.

``REPO`` is the checkout, ``CONFIG`` its config/ folder, ``SHARED`` the read-only shared folder beside
the checkout (../shared: the paper, the URDF, the real recordings).
"""

from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
CONFIG = REPO / "config"
SHARED = REPO.parent / "shared"
