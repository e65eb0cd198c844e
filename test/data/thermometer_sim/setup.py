"""A sensor simulator of a user's own package, written by following docs/extending.md ("A new sensor simulator"):
test_node_registry.py installs it into a folder of its own and runs it in a scenario, touching nothing of rfidnav."""

from setuptools import setup

setup(
    name="rfidnav_thermometer",
    version="0.1.0",
    packages=["rfidnav_thermometer"],
    entry_points={
        "console_scripts": ["thermometer_sim = rfidnav_thermometer.node:main"],
        "rfidnav.nodes": ["thermometer_sim = rfidnav_thermometer.parameters:THERMOMETER_SIM"],
    },
)
