"""Shared by every test folder: pytest puts this folder on ``sys.path`` (``_live_server``)."""
