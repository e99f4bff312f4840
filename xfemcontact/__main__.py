from xfemcontact.cli import main

raise SystemExit(main())
