"""One library call per operation that both the CLI and the service do (the check and its
posting are `checker.check`)."""
