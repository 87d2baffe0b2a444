from dentdemo.cli import main

raise SystemExit(main())
