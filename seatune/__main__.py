from seatune.cli.main import main

main()
