"""Hardware drivers of rfidnav: LLRP RFID reader with phase, iRobot Create base, WiFi scanner."""
