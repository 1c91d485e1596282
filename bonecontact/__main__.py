import sys

from bonecontact.run.cli import main

sys.exit(main())
