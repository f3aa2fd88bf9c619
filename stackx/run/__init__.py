"""Running a plan: one ``stackx run`` (session), where runs step (executor, chunks, cluster), stepping (runner), watching for blow-ups (watch) and what a run hands to outputs (results)."""
