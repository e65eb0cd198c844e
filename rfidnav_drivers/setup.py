from setuptools import find_packages, setup

package_name = "rfidnav_drivers"

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
    description="Hardware drivers of rfidnav: an LLRP RFID reader with phase, the iRobot Create base, a WiFi scanner.",
    license="Apache-2.0",
    entry_points={"console_scripts": [
        "llrp_reader = rfidnav_drivers.llrp_reader_node:main",
        "create_base = rfidnav_drivers.create_base_node:main",
        "wifi_scanner = rfidnav_drivers.wifi_scanner_node:main",
    ], "rfidnav.nodes": [
        "llrp_reader = rfidnav_drivers.parameters:LLRP_READER",
        "create_base = rfidnav_drivers.parameters:CREATE_BASE",
        "wifi_scanner = rfidnav_drivers.parameters:WIFI_SCANNER",
    ]},
)
