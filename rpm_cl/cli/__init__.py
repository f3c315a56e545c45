"""The ``rpm-cl`` command (:mod:`.commands`), its configuration files
(:mod:`.config`), and the drivers behind its commands: ``batch``, ``bench``,
``reproduce`` and the robustness benchmark."""

__all__ = ["build_parser", "main"]


def __getattr__(name):
    # main and build_parser on first use: importing a submodule (the batch
    # worker's config) does not build the command line
    if name in __all__:
        from . import commands

        return getattr(commands, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
