"""A drop-in replacement for PDDLStream's public API: change a script's imports from
``pddlstream.*`` to ``ltamp_cli.pddlstream`` and it plans with ltamp's planner.

See ``docs/porting-from-pddlstream.md`` for what maps to what.
"""

from ltamp_cli.errors import InputError
from ltamp_cli.pddlstream.generator import (
    FunctionInfo,
    PredicateInfo,
    StreamInfo,
    empty_gen,
    empty_test,
    fn_from_constant,
    from_constant,
    from_fn,
    from_gen,
    from_gen_fn,
    from_list_fn,
    from_list_gen_fn,
    from_sampler,
    from_test,
    negate_test,
    universe_test,
)
from ltamp_cli.pddlstream.language import (
    Action,
    And,
    Certificate,
    Equal,
    Exists,
    ForAll,
    Imply,
    Not,
    Or,
    Output,
    PDDLProblem,
    Solution,
    WildOutput,
    get_file_path,
    print_solution,
    read,
)
from ltamp_cli.pddlstream.solve import create_parser, solve

INF = float("inf")

__all__ = ["INF", "Action", "And", "Certificate", "Equal", "Exists", "ForAll", "FunctionInfo",
           "Imply", "InputError", "Not", "Or", "Output", "PDDLProblem", "PredicateInfo",
           "Solution", "StreamInfo", "WildOutput", "create_parser", "empty_gen", "empty_test",
           "fn_from_constant", "from_constant", "from_fn", "from_gen", "from_gen_fn",
           "from_list_fn", "from_list_gen_fn", "from_sampler", "from_test", "get_file_path",
           "negate_test", "print_solution", "read", "solve", "universe_test"]
