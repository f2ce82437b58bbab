"""`python -m biovln_ms.cli`: the command line, as the `biovln-ms` script runs it."""

from biovln_ms.cli import main

if __name__ == "__main__":
    main()
