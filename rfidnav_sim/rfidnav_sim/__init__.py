"""Simulator nodes of rfidnav: differential-drive robot base and UHF RFID reader with per-antenna phase."""
