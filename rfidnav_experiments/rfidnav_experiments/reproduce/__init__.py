"""The papers' experiments reproduced in-process, printed beside the papers' figures."""
