import sys

from tdicam.cli import main

sys.exit(main())
