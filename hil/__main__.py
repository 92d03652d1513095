"""``python -m hil``: the ``hil`` command line (Ctrl-C while it loads: one line, exit 130)."""

import sys

try:
    from hil.cli import main
except KeyboardInterrupt:
    print("hil: interrupted", file=sys.stderr)
    sys.exit(130)

sys.exit(main())
