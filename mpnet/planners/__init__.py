"""Planners behind one protocol: solve(problem, budget) -> Result(path, status, stats)."""

from mpnet.planners.base import EXACT, INVALID_QUERY, NO_SOLUTION, TIMEOUT, Planner, Problem, Result

__all__ = ["EXACT", "INVALID_QUERY", "NO_SOLUTION", "TIMEOUT", "Planner", "Problem", "Result"]
