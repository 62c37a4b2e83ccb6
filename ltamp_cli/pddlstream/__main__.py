"""``python -m ltamp_cli.pddlstream SCRIPT.py [ARGS...]``: run a PDDLStream script
unmodified (see :mod:`ltamp_cli.pddlstream.run`)."""

import sys

from ltamp_cli.pddlstream.run import main

if __name__ == "__main__":
    sys.exit(main())
