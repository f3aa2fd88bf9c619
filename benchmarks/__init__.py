"""Speed benchmark of stackx against plain-Python and C transcriptions of the same algorithms."""
