"""One session of a scenario: the runner, its recording provenance, the expectations it is
judged by and the activity library it loads scripts from."""
