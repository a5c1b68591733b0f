"""Command-line parsing shared by the bag tools."""

from __future__ import annotations

import argparse


class OneLineParser(argparse.ArgumentParser):
    """argparse whose errors are one line on stderr and exit code 2 (no usage block)."""

    def error(self, message: str):
        self.exit(2, f'{self.prog}: {message}\n')
