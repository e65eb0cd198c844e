"""Shared pieces of rfidnav: configuration validation, geometry, seeding, node entry points."""
