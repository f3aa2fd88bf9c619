"""The ``stackx`` command (``python -m stackx``, and the installed script): Ctrl-C is answered in one line
from the very start, before the command line's heavy imports (see ``stackx.run.interrupt``)."""

from stackx.run import interrupt


def main() -> None:
    interrupt.install()

    def command() -> None:
        from stackx.cli import main as cli  # typer, rich: a few tenths of a second

        cli()

    interrupt.run(command)


if __name__ == "__main__":
    main()
