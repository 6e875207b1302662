"""``sdfpbr bugs``: list the catalogued PBR mistakes."""


def register(sub) -> None:
    p = sub.add_parser("bugs", help="list the PBR mistakes that --bug / compare --bug can switch on")
    p.add_argument("-v", "--verbose", action="store_true", help="also print each caption and the option it sets")
    p.set_defaults(run=run)


def run(args) -> int:
    from ...spec.bugs import BUGS
    width = max(len(n) for n in BUGS)
    for bug in BUGS.values():
        print(f"{bug.name:{width}s}  {bug.summary}")
        if args.verbose:
            needs = ", ".join(f"{k}={v}" for k, v in bug.requires.items())
            print(f"{'':{width}s}  {bug.caption}")
            print(f"{'':{width}s}  sets {bug.option}={bug.value} in the {bug.program} program"
                  + (f"; needs {needs}" if needs else ""))
    return 0
