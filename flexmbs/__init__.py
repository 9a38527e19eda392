"""flexmbs: the command line and the application layer (reports, benchmarks) around the engine."""

__version__ = "0.1.0"
