from pathlib import Path

from setuptools import find_packages, setup

package_name = "rfidnav_scenario"
# The suite's configuration (scenarios, worlds, maps, parameters, robot profiles) lives at the workspace root
# and installs to share/rfidnav_scenario/config, where rfidnav_scenario.scenario finds it.
config_files = sorted(p.relative_to(Path(__file__).resolve().parent.parent)
                      for p in (Path(__file__).resolve().parent.parent / "config").rglob("*") if p.is_file())

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        *((f"share/{package_name}/{path.parent}", [f"../{path}"]) for path in config_files),
    ],
    install_requires=["setuptools"],
    extras_require={"test": ["pytest"]},   # colcon test runs pytest here: this package's share of test/ (conftest.py)
    zip_safe=True,
    maintainer="rfidnav developers",
    description="The scenario model of rfidnav: scenario files and their checks, the node registry, run metrics.",
    license="Apache-2.0",
)
