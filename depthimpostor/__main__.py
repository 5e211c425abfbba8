from depthimpostor.cli import main

raise SystemExit(main())
