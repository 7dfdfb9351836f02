import sys

from precise_impact.cli.main import main

sys.exit(main())
