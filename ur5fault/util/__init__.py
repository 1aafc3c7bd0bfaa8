"""Utilities that know nothing of robots: atomic writers, the one YAML loader, checks of single values,
progress display and provenance."""
