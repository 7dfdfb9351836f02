from precise_impact.cli.entry import run

run()
