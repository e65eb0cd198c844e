"""Localizers of rfidnav: the RFID space-partition localizer (paper 000)."""
