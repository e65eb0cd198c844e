from setuptools import find_packages, setup

package_name = "rfidnav_control"

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
    description="Controllers of rfidnav: the fuzzy heading controller (paper 001), spiral search and go-to (003), "
                "sonar wall following (004).",
    license="Apache-2.0",
    entry_points={"console_scripts": [
        "heading_controller = rfidnav_control.heading_controller_node:main",
        "wall_follower = rfidnav_control.wall_follower_node:main",
    ], "rfidnav.nodes": [
        "heading_controller = rfidnav_control.parameters:HEADING_CONTROLLER",
        "wall_follower = rfidnav_control.parameters:WALL_FOLLOWER",
    ]},
)
