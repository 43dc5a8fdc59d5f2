"""What a run needs, built on first use into the content-keyed cache: test sets, datasets
and trained networks (ensure), DAgger's rounds (dagger), and the training itself (fit,
fit_progress).

Deliberately empty: a module here is imported by its own name (Lightning loads with fit only)."""
