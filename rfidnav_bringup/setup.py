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
    zip_safe=True,
    maintainer="rfidnav developers",
    description="Orchestration of rfidnav: scenarios, process runner, MCAP recorder and player, metrics, reports, experiments, CLI.",
    license="Apache-2.0",
    entry_points={"console_scripts": [
        "recorder = rfidnav_bringup.recorder_node:main",
        "player = rfidnav_bringup.player_node:main",
    ]},
)
