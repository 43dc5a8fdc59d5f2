"""Test sets, expert paths and datasets on disk."""
