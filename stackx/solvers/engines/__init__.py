"""Physics engines as solver plugins: pymunk, Box2D 2.3, Box2D v3 and MuJoCo step the same scenes as stackx's
own solvers and are judged by the same measures.

Each engine has its own module, registered as a built-in solver; the engine's Python package is imported only
when a run is set up (``stackx.solvers.engines.engine`` says how), so listing plugins, validating configs and
``stackx --help`` never load it, and an engine that is not installed is listed with the command that installs it
(``pip install 'stackx[engines]'``).
"""
