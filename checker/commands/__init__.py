"""Click subcommands of `pathcheck`, one module each; each parses, calls the library, formats."""
