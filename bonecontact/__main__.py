import sys

from bonecontact.runners.cli import main

sys.exit(main())
