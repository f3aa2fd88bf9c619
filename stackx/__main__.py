"""The ``stackx`` command (``python -m stackx``, and the installed script).

``main`` first installs the answer to Ctrl-C and SIGTERM; before it, this module imports only
``stackx.run.interrupt`` (``os``, ``signal`` and ``sys``), so from the first millisecond of stackx's own code a
signal gets one line, never a traceback. Everything else, the command line's typer and rich included, is
imported after that. Importing this module installs nothing: multiprocessing's spawn (Dask's workers) runs
the installed script again in each worker, which must keep its own signals.
"""

from stackx.run import interrupt


def main() -> None:
    interrupt.install()
    interrupt.run(_command_line)


def _command_line() -> None:
    from stackx.cli import main as cli  # typer, rich: a few tenths of a second

    cli()


if __name__ == "__main__":
    main()
