"""Helpers the test modules share: a node graph on one executor, CLI runs, an LLRP emulator loop, config copies,
a fake iRobot Create. Test modules import from here, never from one another."""
