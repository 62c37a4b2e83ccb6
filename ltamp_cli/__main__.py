from ltamp_cli.cli.app import main

main()
