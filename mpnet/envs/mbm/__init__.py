"""MotionBenchMaker (Chamzas et al., RA-L 2022) for the Panda: its seven scene families as
seeded generators (scenes), panda_mbm's generator of one problem per call (generator), and
the reader of MBM's scene/request YAML pairs as a test set (files). The command that fetches
them is harness/fetch_mbm.py.

Deliberately empty: a module here is imported by its own name."""
