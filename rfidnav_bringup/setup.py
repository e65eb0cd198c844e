from pathlib import Path

from setuptools import find_packages, setup

package_name = "rfidnav_bringup"
# The suite's configuration (scenarios, worlds, maps, parameters, robot profiles) lives at the workspace root
# and installs to share/rfidnav_bringup/config, where rfidnav_bringup.scenario finds it.
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
    description="Orchestration of rfidnav: the CLI, scenarios, node processes, the orchestrator, metrics, reports.",
    license="Apache-2.0",
    # The command line as an executable of the package: <install>/lib/rfidnav_bringup/rfidnav VERB in a colcon install.
    entry_points={"console_scripts": ["rfidnav = rfidnav_bringup.cli:main"]},
)
