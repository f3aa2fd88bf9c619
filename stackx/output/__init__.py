"""Writing: the output folder (outdir), its manifest, ``stackx verify``, ``stackx serve``, and the terminal's tables (screen)."""
