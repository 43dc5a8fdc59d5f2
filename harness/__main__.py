"""`python -m harness ...`: the bench (harness.bench.command).

Nothing is imported at module level: a sweep's job and every run's log process are spawned
interpreters, which import this module again (as `__mp_main__`) before they start; hydra's
import alone cost each of them ~0.15 s."""

if __name__ == "__main__":
    from harness.bench.command import run

    run()
