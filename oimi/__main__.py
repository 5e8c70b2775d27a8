from oimi.cli import main

raise SystemExit(main())
