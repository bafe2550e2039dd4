import sys

from mocapkit.cli import main

sys.exit(main())
