# polydem jam: CLI tests (issue 15). See cli_helpers.cmake.
