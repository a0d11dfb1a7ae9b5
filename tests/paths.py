"""Where the repository's own files are, for tests in any folder below tests/."""

from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
"""The checkout's root: mapush/, tools/, results/, docs/."""
