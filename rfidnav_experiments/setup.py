from setuptools import find_packages, setup

package_name = "rfidnav_experiments"

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
    description="In-process experiments of rfidnav: runners, the papers' reproductions, benchmarks.",
    license="Apache-2.0",
    entry_points={"rfidnav.verbs": [
        "reproduce = rfidnav_experiments.reproduce.driver:add_reproduce",
        "calibrate = rfidnav_experiments.verbs:add_calibrate",
        "survey = rfidnav_experiments.verbs:add_survey",
        "bench = rfidnav_experiments.verbs:add_bench",
    ], "rfidnav.reproductions": [   # rfidnav_experiments.reproduce.driver
        "flc = rfidnav_experiments.reproduce.entries:FLC",
        "partitions = rfidnav_experiments.reproduce.entries:PARTITIONS",
        "two_tier = rfidnav_experiments.reproduce.entries:TWO_TIER",
        "topological = rfidnav_experiments.reproduce.entries:TOPOLOGICAL",
        "fused = rfidnav_experiments.reproduce.entries:FUSED",
    ]},
)
