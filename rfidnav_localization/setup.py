from setuptools import find_packages, setup

package_name = "rfidnav_localization"

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
    description=("Localizers of rfidnav: the RFID space-partition localizer (paper 000), the WiFi/RFID location "
                 "server (paper 003)."),
    license="Apache-2.0",
    entry_points={"console_scripts": [
        "partition_localizer = rfidnav_localization.partition_localizer_node:main",
        "location_server = rfidnav_localization.location_server_node:main",
        "rfid_localizer = rfidnav_localization.rfid_localizer_node:main",
    ], "rfidnav.nodes": [
        "partition_localizer = rfidnav_localization.parameters:PARTITION_LOCALIZER",
        "location_server = rfidnav_localization.parameters:LOCATION_SERVER",
        "rfid_localizer = rfidnav_localization.parameters:RFID_LOCALIZER",
    ]},
)
