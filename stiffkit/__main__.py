from stiffkit.cli import main

raise SystemExit(main())
