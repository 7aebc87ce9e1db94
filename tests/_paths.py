"""Where the suite finds its files, wherever a test module sits in the tests/ tree."""

from pathlib import Path

TESTS = Path(__file__).resolve().parent   # tests/
DATA = TESTS / "data"                      # fixtures: TLEs, transcripts, plan files
REPO = TESTS.parent                        # the checkout: tracker/, tle/, docs/, examples/
