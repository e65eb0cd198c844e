from setuptools import find_packages, setup

package_name = "rfidnav_planning"

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
    description=("Planners and navigators of rfidnav: the partition path planner and navigator (paper 000), the "
                 "two-tier navigator (paper 003)."),
    license="Apache-2.0",
    entry_points={"console_scripts": [
        "partition_navigator = rfidnav_planning.partition_navigator_node:main",
        "two_tier_navigator = rfidnav_planning.two_tier_navigator_node:main",
        "pose_navigator = rfidnav_planning.pose_navigator_node:main",
        "mission_executor = rfidnav_planning.mission_executor_node:main",
    ], "rfidnav.nodes": [
        "partition_navigator = rfidnav_planning.parameters:PARTITION_NAVIGATOR",
        "two_tier_navigator = rfidnav_planning.parameters:TWO_TIER_NAVIGATOR",
        "pose_navigator = rfidnav_planning.parameters:POSE_NAVIGATOR",
        "mission_executor = rfidnav_planning.parameters:MISSION_EXECUTOR",
    ]},
)
