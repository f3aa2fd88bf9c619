"""Allow ``python -m stackx``."""

from stackx.cli import main

main()
