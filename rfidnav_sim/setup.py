from setuptools import find_packages, setup

package_name = "rfidnav_sim"

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
    description=("Simulator nodes of rfidnav: differential-drive robot base, UHF RFID reader with per-antenna phase, "
                 "e-compass, WiFi RSS scans, sonar."),
    license="Apache-2.0",
    entry_points={"console_scripts": [
        "robot_sim = rfidnav_sim.robot_sim_node:main",
        "rfid_reader_sim = rfidnav_sim.rfid_reader_sim_node:main",
        "compass_sim = rfidnav_sim.compass_sim_node:main",
        "wifi_sim = rfidnav_sim.wifi_sim_node:main",
        "sonar_sim = rfidnav_sim.sonar_sim_node:main",
    ], "rfidnav.nodes": [
        "robot_sim = rfidnav_sim.parameters:ROBOT_SIM",
        "rfid_reader_sim = rfidnav_sim.parameters:RFID_READER_SIM",
        "compass_sim = rfidnav_sim.parameters:COMPASS_SIM",
        "wifi_sim = rfidnav_sim.parameters:WIFI_SIM",
        "sonar_sim = rfidnav_sim.parameters:SONAR_SIM",
    ]},
)
