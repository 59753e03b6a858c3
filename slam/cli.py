"""Command line interface: ``slam``."""
import click


@click.group()
def main() -> None:
    """Workbench for nonlinear navigation filters."""
