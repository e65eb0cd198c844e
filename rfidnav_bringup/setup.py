from setuptools import find_packages, setup

package_name = "rfidnav_bringup"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    extras_require={"test": ["pytest"]},   # colcon test runs pytest here: this package's share of test/ (conftest.py)
    zip_safe=True,
    maintainer="rfidnav developers",
    description="Orchestration of rfidnav: the CLI, node processes, the orchestrator, reports.",
    license="Apache-2.0",
    # The command line as an executable of the package: <install>/lib/rfidnav_bringup/rfidnav VERB in a colcon install.
    entry_points={"console_scripts": ["rfidnav = rfidnav_bringup.cli:main"]},
)
