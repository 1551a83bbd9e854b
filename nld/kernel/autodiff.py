"""Forward-mode differentiation of generated (and small hand-written) numba source.

The tangent (variational) dynamics of a scene need the exact Jacobian-vector product of its
kernel's right-hand side, event functions and event resets (docs/lyapunov.md). The kernel is
straight-line scalar code written by ``nld.kernel.codegen``; this module differentiates that *source*
statement by statement (forward mode, "tangent-linear code"), so the derivative holds exactly the
terms the scene has and nothing else, and stays in step with the code generator by construction.

``jvp_source(src, active, ...)`` takes the source of one function and returns the source of a new
function computing the primal results *and* their directional derivatives. For an argument ``a``
marked active, a new argument ``a__d`` (same shape) holds its tangent; every assignment to an
active variable ``v`` is followed by one to ``v__d``; an output array ``out`` written by the
function gets ``out__d`` written alongside. Calls to other functions (contact and friction laws,
``slip_velocity``, ``periodic_table``) are differentiated the same way, specialised for the
arguments that are active in the call (``name__jvp<mask>`` returning ``(value, derivative)``).

Supported: assignments (names and subscripts, slices), augmented assignments, ``if``/``elif``,
``for ... in range``, ``while``, ``break``, ``return``, conditional expressions, ``+ - * / ** %``,
unary minus, ``np.sin/cos/tan/sqrt/exp/log/arctan2``, ``math.*`` of the same, ``abs``, ``max``,
``min`` (two arguments), ``np.linalg.solve``, ``np.empty/np.zeros``; comparisons and boolean
operations are not differentiated (piecewise-smooth code: the derivative is that of the branch
taken, which is what the tangent dynamics between events need; the jumps between branches are the
saltation matrices' job).
"""
from __future__ import annotations

import ast
import inspect
import textwrap

D = "__d"            # suffix of a derivative variable

_UNARY_NP = {"sin", "cos", "tan", "sqrt", "exp", "log", "arctan", "tanh", "sinh", "cosh", "atan"}
_NON_DIFF = {"isfinite", "isnan", "floor", "ceil", "sign", "int", "float", "bool", "round", "len",
             "range"}


class AutodiffError(ValueError):
    """A construct the forward-mode transformer does not know."""


def _name(node) -> str | None:
    return node.id if isinstance(node, ast.Name) else None


def _call_name(node: ast.Call) -> str:
    f = node.func
    if isinstance(f, ast.Name):
        return f.id
    if isinstance(f, ast.Attribute):
        parts = []
        while isinstance(f, ast.Attribute):
            parts.append(f.attr)
            f = f.value
        if isinstance(f, ast.Name):
            parts.append(f.id)
        return ".".join(reversed(parts))
    raise AutodiffError(f"call of {ast.unparse(node.func)}")


def _base(node) -> str | None:
    """The array name of a subscript chain (``a[1]``, ``a[1, 2]``, ``a[:3]``)."""
    while isinstance(node, ast.Subscript):
        node = node.value
    return _name(node)


def _zero() -> ast.expr:
    return ast.Constant(0.0)


def _is_zero(e: ast.expr) -> bool:
    return isinstance(e, ast.Constant) and e.value == 0.0


def _add(a, b):
    if _is_zero(a):
        return b
    if _is_zero(b):
        return a
    return ast.BinOp(a, ast.Add(), b)


def _sub(a, b):
    if _is_zero(b):
        return a
    if _is_zero(a):
        return ast.UnaryOp(ast.USub(), b)
    return ast.BinOp(a, ast.Sub(), b)


def _mul(a, b):
    if _is_zero(a) or _is_zero(b):
        return _zero()
    if isinstance(a, ast.Constant) and a.value == 1.0:
        return b
    if isinstance(b, ast.Constant) and b.value == 1.0:
        return a
    return ast.BinOp(a, ast.Mult(), b)


def _div(a, b):
    if _is_zero(a):
        return _zero()
    return ast.BinOp(a, ast.Div(), b)


def _np(attr: str, *args) -> ast.expr:
    return ast.Call(ast.Attribute(ast.Name("np", ast.Load()), attr, ast.Load()), list(args), [])


def _copy(e):
    import copy
    return copy.deepcopy(e)


class _Activity(ast.NodeVisitor):
    """Fixed point of 'depends on an active input' over the names of a function body."""

    def __init__(self, active: set[str], known: dict):
        self.active = set(active)
        self.known = known
        self.changed = True

    def expr_active(self, e) -> bool:
        if e is None:
            return False
        if isinstance(e, ast.Name):
            return e.id in self.active
        if isinstance(e, ast.Constant):
            return False
        if isinstance(e, (ast.Compare, ast.BoolOp)):
            return False
        if isinstance(e, ast.UnaryOp) and isinstance(e.op, ast.Not):
            return False
        if isinstance(e, ast.Subscript):
            return self.expr_active(e.value)
        if isinstance(e, ast.Call):
            nm = _call_name(e)
            short = nm.split(".")[-1]
            if short in _NON_DIFF or nm in ("np.empty", "np.zeros"):
                return False
            return any(self.expr_active(a) for a in e.args)
        if isinstance(e, ast.IfExp):
            return self.expr_active(e.body) or self.expr_active(e.orelse)
        return any(self.expr_active(c) for c in ast.iter_child_nodes(e)
                   if isinstance(c, ast.expr))

    def mark(self, target, value_active: bool):
        if not value_active:
            return
        nm = _name(target) if isinstance(target, ast.Name) else _base(target)
        if nm is None:
            if isinstance(target, ast.Tuple):
                for t in target.elts:
                    self.mark(t, True)
                return
            raise AutodiffError(f"assignment to {ast.unparse(target)}")
        if nm not in self.active:
            self.active.add(nm)
            self.changed = True

    def visit_Assign(self, node):
        a = self.expr_active(node.value)
        for t in node.targets:
            self.mark(t, a)

    def visit_AugAssign(self, node):
        self.mark(node.target, self.expr_active(node.value) or self.expr_active(
            node.target if isinstance(node.target, ast.Name) else ast.Name(_base(node.target))))

    def visit_For(self, node):
        for s in node.body + node.orelse:
            self.visit(s)


class _Transformer:
    """Emits the tangent-linear statements of one function."""

    def __init__(self, active_inputs: set[str], known: dict, frozen: set[str], registry):
        self.known = known            # name -> python source of callable functions we may diff
        self.frozen = frozen          # arrays whose writes get no derivative write
        self.registry = registry      # shared: generated helper functions
        self.tmp = 0
        self.active: set[str] = set(active_inputs)

    # ------------------------------------------------------------------ analysis
    def analyse(self, body):
        act = _Activity(self.active, self.known)
        while act.changed:
            act.changed = False
            for s in body:
                act.visit(s)
        self.active = act.active
        self._act = act

    def is_active(self, e) -> bool:
        return self._act.expr_active(e)

    def dname(self, nm: str) -> str:
        return nm + D

    # ------------------------------------------------------------------ expressions
    def d(self, e: ast.expr, pre: list) -> ast.expr:
        """Derivative expression of e (may append hoisted statements to ``pre``)."""
        if not self.is_active(e):
            return _zero()
        if isinstance(e, ast.Name):
            return ast.Name(self.dname(e.id), ast.Load())
        if isinstance(e, ast.Subscript):
            return ast.Subscript(self._dsub_value(e.value), _copy(e.slice), ast.Load())
        if isinstance(e, ast.UnaryOp):
            if isinstance(e.op, ast.USub):
                de = self.d(e.operand, pre)
                return _zero() if _is_zero(de) else ast.UnaryOp(ast.USub(), de)
            if isinstance(e.op, ast.UAdd):
                return self.d(e.operand, pre)
            raise AutodiffError(f"unary {ast.unparse(e)}")
        if isinstance(e, ast.BinOp):
            a, b = e.left, e.right
            da, db = self.d(a, pre), self.d(b, pre)
            op = e.op
            if isinstance(op, ast.Add):
                return _add(da, db)
            if isinstance(op, ast.Sub):
                return _sub(da, db)
            if isinstance(op, ast.Mult):
                return _add(_mul(da, _copy(b)), _mul(_copy(a), db))
            if isinstance(op, ast.Div):
                # (a/b)' = (a' - (a/b) b') / b
                if _is_zero(db):
                    return _div(da, _copy(b))
                return _div(_sub(da, _mul(_copy(e), db)), _copy(b))
            if isinstance(op, ast.Pow):
                if _is_zero(db):
                    if isinstance(b, ast.Constant) and b.value == 2:
                        return _mul(_mul(ast.Constant(2.0), _copy(a)), da)
                    ex = ast.BinOp(_copy(b), ast.Sub(), ast.Constant(1.0))
                    return _mul(_mul(_copy(b), ast.BinOp(_copy(a), ast.Pow(), ex)), da)
                # general: a**b (b' log a + b a'/a)
                t1 = _mul(db, _np("log", _copy(a)))
                t2 = _div(_mul(_copy(b), da), _copy(a))
                return _mul(_copy(e), _add(t1, t2))
            if isinstance(op, ast.Mod):
                if not _is_zero(db):
                    raise AutodiffError(f"modulus by an active value: {ast.unparse(e)}")
                return da
            if isinstance(op, ast.MatMult):
                return _add(ast.BinOp(da, ast.MatMult(), _copy(b)) if not _is_zero(da) else _zero(),
                            ast.BinOp(_copy(a), ast.MatMult(), db) if not _is_zero(db) else _zero())
            raise AutodiffError(f"operator in {ast.unparse(e)}")
        if isinstance(e, ast.IfExp):
            db, do = self.d(e.body, pre), self.d(e.orelse, pre)
            return ast.IfExp(_copy(e.test), db, do)
        if isinstance(e, ast.Call):
            return self.d_call(e, pre)
        raise AutodiffError(f"expression {ast.unparse(e)}")

    def _dsub_value(self, v):
        if isinstance(v, ast.Name):
            return ast.Name(self.dname(v.id), ast.Load())
        if isinstance(v, ast.Subscript):
            return ast.Subscript(self._dsub_value(v.value), _copy(v.slice), ast.Load())
        raise AutodiffError(f"subscript of {ast.unparse(v)}")

    def d_call(self, e: ast.Call, pre: list) -> ast.expr:
        nm = _call_name(e)
        short = nm.split(".")[-1]
        args = e.args
        if nm in ("abs", "math.fabs", "np.abs", "np.fabs"):
            (u,) = args
            du = self.d(u, pre)
            return ast.IfExp(ast.Compare(_copy(u), [ast.GtE()], [_zero()]), du,
                             ast.UnaryOp(ast.USub(), du))
        if nm in ("max", "min", "np.maximum", "np.minimum"):
            if len(args) != 2:
                raise AutodiffError(f"{nm} with {len(args)} arguments")
            u, v = args
            op = ast.GtE() if short in ("max", "maximum") else ast.LtE()
            return ast.IfExp(ast.Compare(_copy(u), [op], [_copy(v)]), self.d(u, pre), self.d(v, pre))
        if nm.startswith(("np.", "math.")) and short in _UNARY_NP and len(args) == 1:
            u = args[0]
            du = self.d(u, pre)
            lib = nm.split(".")[0]
            f = lambda a, x: ast.Call(ast.Attribute(ast.Name(lib, ast.Load()), a, ast.Load()),
                                      [x], [])
            if short == "sin":
                return _mul(f("cos", _copy(u)), du)
            if short == "cos":
                return ast.UnaryOp(ast.USub(), _mul(f("sin", _copy(u)), du))
            if short == "tan":
                return _div(du, ast.BinOp(f("cos", _copy(u)), ast.Pow(), ast.Constant(2)))
            if short == "exp":
                return _mul(_copy(e), du)
            if short == "log":
                return _div(du, _copy(u))
            if short == "sqrt":     # derivative 0 where the root is 0 (|e| at a centred journal)
                s = _copy(e)
                return ast.IfExp(ast.Compare(s, [ast.Gt()], [_zero()]),
                                 _div(_mul(ast.Constant(0.5), du), _copy(e)), _zero())
            if short in ("arctan", "atan"):
                return _div(du, ast.BinOp(ast.Constant(1.0), ast.Add(),
                                          ast.BinOp(_copy(u), ast.Pow(), ast.Constant(2))))
            if short == "tanh":
                return _mul(ast.BinOp(ast.Constant(1.0), ast.Sub(),
                                      ast.BinOp(_copy(e), ast.Pow(), ast.Constant(2))), du)
            if short == "sinh":
                return _mul(f("cosh", _copy(u)), du)
            if short == "cosh":
                return _mul(f("sinh", _copy(u)), du)
        if nm in ("np.arctan2", "math.atan2"):
            yv, xv = args
            dy_, dx_ = self.d(yv, pre), self.d(xv, pre)
            den = ast.BinOp(ast.BinOp(_copy(xv), ast.Pow(), ast.Constant(2)), ast.Add(),
                            ast.BinOp(_copy(yv), ast.Pow(), ast.Constant(2)))
            return _div(_sub(_mul(_copy(xv), dy_), _mul(_copy(yv), dx_)), den)
        if nm == "np.linalg.solve":
            # x = A^-1 b: x' = A^-1 (b' - A' x); hoisted so x is computed once
            A, b = args
            tmp = self.new_tmp()
            pre.append(ast.Assign([ast.Name(tmp, ast.Store())], _copy(e), lineno=0))
            e.__dict__["_hoisted"] = tmp
            rhs = self.d(b, pre)
            dA = self.d(A, pre)
            if not _is_zero(dA):
                rhs = _sub(rhs, ast.BinOp(dA, ast.MatMult(), ast.Name(tmp, ast.Load())))
            if _is_zero(rhs):
                return _zero()
            return ast.Call(ast.Attribute(ast.Attribute(ast.Name("np", ast.Load()), "linalg",
                                                        ast.Load()), "solve", ast.Load()),
                            [_copy(A), rhs], [])
        if short in self.known:
            mask = "".join("1" if self.is_active(a) else "0" for a in args)
            fname = self.registry.function(short, mask)
            tmp = self.new_tmp()
            dargs = [self.d(a, pre) for a, m in zip(args, mask) if m == "1"]
            call = ast.Call(ast.Name(fname, ast.Load()), [_copy(a) for a in args] + dargs, [])
            pre.append(ast.Assign([ast.Tuple([ast.Name(tmp, ast.Store()),
                                              ast.Name(tmp + D, ast.Store())], ast.Store())],
                                  call, lineno=0))
            e.__dict__["_hoisted"] = tmp
            return ast.Name(tmp + D, ast.Load())
        raise AutodiffError(f"call of {nm}: no derivative rule")

    def new_tmp(self) -> str:
        self.tmp += 1
        return f"_ad{self.tmp}"

    def primal(self, e):
        """The primal expression with hoisted calls replaced by their temporaries."""
        class R(ast.NodeTransformer):
            def visit_Call(s, node):
                if "_hoisted" in node.__dict__:
                    return ast.Name(node.__dict__["_hoisted"], ast.Load())
                s.generic_visit(node)
                return node
        return R().visit(e)

    # ------------------------------------------------------------------ statements
    def stmts(self, body) -> list:
        out = []
        for s in body:
            out += self.stmt(s)
        return out

    def stmt(self, s) -> list:
        if isinstance(s, ast.Assign):
            if len(s.targets) != 1:
                raise AutodiffError("chained assignment")
            tgt = s.targets[0]
            pre: list = []
            if isinstance(s.value, ast.Call) and _call_name(s.value) in ("np.empty", "np.zeros"):
                res = [s]
                nm = _base(tgt)
                if nm in self._act.active and isinstance(tgt, ast.Name):
                    res.append(ast.Assign([ast.Name(self.dname(nm), ast.Store())],
                                          _np("zeros", _copy(s.value.args[0])), lineno=0))
                return res
            if isinstance(tgt, ast.Tuple):
                names = [_name(t) for t in tgt.elts]
                if None in names:
                    raise AutodiffError(f"assignment to {ast.unparse(tgt)}")
                if not any(n in self.active for n in names):
                    return [s]
                if not (isinstance(s.value, ast.Tuple) and len(s.value.elts) == len(names)):
                    raise AutodiffError(f"unpacking of {ast.unparse(s.value)}")
                tmps = [self.new_tmp() for _ in names]
                res = []
                for t, v in zip(tmps, s.value.elts):
                    if self.is_active(v):
                        self._act.active.add(t)
                    res += self.stmt(ast.Assign([ast.Name(t, ast.Store())], v, lineno=0))
                for n_, t in zip(names, tmps):
                    res += self.stmt(ast.Assign([ast.Name(n_, ast.Store())], ast.Name(t, ast.Load()),
                                                lineno=0))
                return res
            nm = _name(tgt) if isinstance(tgt, ast.Name) else _base(tgt)
            if nm is None:
                raise AutodiffError(f"assignment to {ast.unparse(tgt)}")
            if nm not in self._act.active or nm in self.frozen:
                return [s]
            dv = self.d(s.value, pre)
            s.value = self.primal(s.value)
            if isinstance(tgt, ast.Name):
                dt = ast.Name(self.dname(nm), ast.Store())
            else:
                dt = ast.Subscript(self._dsub_value(tgt.value), _copy(tgt.slice), ast.Store())
            # the derivative first: it reads the operands' old values (x = x / d)
            return pre + [ast.Assign([dt], dv, lineno=0), s]
        if isinstance(s, ast.AugAssign):
            tgt = s.target
            nm = _name(tgt) if isinstance(tgt, ast.Name) else _base(tgt)
            if nm not in self._act.active or nm in self.frozen:
                return [s]
            pre = []
            dv = self.d(s.value, pre)
            if isinstance(s.op, (ast.Add, ast.Sub)):
                dexpr, dop = dv, s.op
                res = list(pre)
                if not _is_zero(dexpr):
                    dt = (ast.Name(self.dname(nm), ast.Store()) if isinstance(tgt, ast.Name) else
                          ast.Subscript(self._dsub_value(tgt.value), _copy(tgt.slice), ast.Store()))
                    res.append(ast.AugAssign(dt, dop, dexpr))
                res.append(ast.AugAssign(_copy(tgt), s.op, self.primal(s.value)))
                return res
            # x *= v, x /= v: rewrite as x = x op v
            load = _copy(tgt)
            load.ctx = ast.Load()
            new = ast.Assign([_copy(tgt)], ast.BinOp(load, s.op, s.value), lineno=0)
            return self.stmt(new)
        if isinstance(s, ast.If):
            return [ast.If(s.test, self.stmts(s.body) or [ast.Pass()], self.stmts(s.orelse))]
        if isinstance(s, ast.For):
            return [ast.For(s.target, s.iter, self.stmts(s.body), self.stmts(s.orelse),
                            lineno=0)]
        if isinstance(s, ast.While):
            return [ast.While(s.test, self.stmts(s.body), self.stmts(s.orelse))]
        if isinstance(s, (ast.Break, ast.Continue, ast.Pass)):
            return [s]
        if isinstance(s, ast.Return):
            return [s]
        if isinstance(s, ast.Expr):
            if isinstance(s.value, ast.Constant):      # docstring
                return []
            if self.is_active(s.value):
                raise AutodiffError(f"statement {ast.unparse(s)} with an active value")
            return [s]
        raise AutodiffError(f"statement {ast.unparse(s)}")


class Registry:
    """Helper functions differentiated on demand (the laws a kernel calls)."""

    def __init__(self, known: dict, decorator: str):
        self.known = known          # short name -> source text
        self.decorator = decorator
        self.sources: dict[str, str] = {}

    def function(self, name: str, mask: str) -> str:
        fname = f"{name}__jvp{mask}"
        if fname in self.sources:
            return fname
        self.sources[fname] = ""      # reserve (recursion guard)
        tree = ast.parse(textwrap.dedent(self.known[name]))
        fn = tree.body[0]
        args = [a.arg for a in fn.args.args]
        active = {a for a, m in zip(args, mask) if m == "1"}
        tr = _Transformer(active, self.known, set(), self)
        tr.analyse(fn.body)
        body = tr.stmts(fn.body)
        # every return gives (value, derivative)
        class Ret(ast.NodeTransformer):
            def visit_Return(s, node):
                v = node.value if node.value is not None else ast.Constant(0.0)
                pre: list = []
                dv = tr.d(v, pre)
                node = ast.Return(ast.Tuple([tr.primal(v), dv], ast.Load()))
                return pre + [node] if pre else node
        body = [Ret().visit(b) for b in body]
        flat = []
        for b in body:
            flat += b if isinstance(b, list) else [b]
        new = ast.FunctionDef(fname, ast.arguments(
            [], [ast.arg(a) for a in args] + [ast.arg(a + D) for a in args if a in active],
            None, [], [], None, []), flat, [], lineno=0)
        src = self.decorator + "\n" + ast.unparse(ast.fix_missing_locations(new))
        self.sources[fname] = src
        return fname


def jvp_source(src: str, *, name: str, active: list[str], outputs: list[str],
               frozen: list[str] = (), known: dict | None = None,
               registry: Registry | None = None) -> str:
    """Source of ``name``: the function in ``src`` with tangent inputs and outputs.

    active: arguments whose tangents are inputs (``a__d`` appended to the argument list in this
    order); outputs: arrays the function writes whose tangents are outputs (``out__d`` appended
    after the active tangents); frozen: arrays whose writes get no derivative (e.g. a kernel's
    warm-start cache in ``z``). ``known``: name -> source of functions it may call (contact laws,
    ...), differentiated into ``registry``."""
    tree = ast.parse(textwrap.dedent(src))
    fn = tree.body[0]
    reg = registry if registry is not None else Registry(known or {}, "")
    tr = _Transformer(set(active), known or {}, set(frozen), reg)
    tr.analyse(fn.body)
    for o in outputs:
        tr._act.active.add(o)
    body = tr.stmts(fn.body)
    args = [a.arg for a in fn.args.args]
    new_args = args + [a + D for a in active] + [o + D for o in outputs if o not in active]
    new = ast.FunctionDef(name, ast.arguments([], [ast.arg(a) for a in new_args], None, [], [],
                                              None, []), body or [ast.Pass()], [], lineno=0)
    return ast.unparse(ast.fix_missing_locations(new))


def function_source(func) -> str:
    """Source text of a (numba) function without its decorators."""
    f = getattr(func, "py_func", func)
    src = textwrap.dedent(inspect.getsource(f))
    tree = ast.parse(src)
    fn = tree.body[0]
    fn.decorator_list = []
    return ast.unparse(fn)
