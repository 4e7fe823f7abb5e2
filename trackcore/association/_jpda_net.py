"""Exact JPDA marginals without enumerating the joint events: a hypothesis net.

A feasible joint event is a matching in the bipartite validation graph between the
measurements and the targets.  Its weight is a product of one factor per element:

* a matched pair ``(j, t)``: ``w_{jt} = P_D^t rho_{jt} N_{jt} / lambda`` (parametric form),
* an unmatched target: ``1 - P_D^t``; an unmatched measurement: 1,

and, in the nonparametric form, a factor ``g(d)`` of the total number ``d`` of matched
pairs (``phi! / V^phi`` with ``phi = m - d``).

The net processes the elements of one side in a fixed order ("layers").  After layer
``k`` the only thing the rest of the problem needs to know about the choices made so
far is which elements of the other side are already used *among those still adjacent
to an unprocessed element* (the frontier), and, in the nonparametric form, how many
pairs were matched.  The partial assignments are therefore merged into one node per
(frontier subset, count): the node's forward weight sums all partial assignments that
lead to it, its backward weight all completions (Maskell's efficient hypothesis
management, with the conditional independence of separated groups of Horridge &
Maskell exploited by the ordering and by processing the connected components of the
validation graph one after the other).  A marginal is the sum, over the net's edges that
choose it, of forward weight x edge weight x backward weight, over the total.

Choices made here:

* The processed side is chosen per connected component: targets ("A": nodes are subsets
  of measurements) or measurements ("B": nodes are subsets of targets), whichever gives
  the cheaper net by the estimate ``sum_k 2^{frontier_k} (1 + degree_k)``.
* The order within a component is greedy: next the element whose processing leaves the
  smallest frontier (ties: the smaller intermediate frontier, then the lower index).
* Frontier elements occupy bit slots (the lowest free slot when an element enters the
  frontier, freed when it leaves); a layer's nodes are the ``2^{slots}`` masks, stored
  densely.  Forward weights are kept for every layer, each layer scaled to a maximum of
  1 (its logarithm kept aside, restarted at every connected component in the
  parametric form); every processed element's options are scaled to a maximum of 1 as
  well, so nothing overflows.
* Underflow is excluded by a certificate, not assumed away: layer by layer, from the
  smallest nonzero value actually stored in the layer before and the smallest nonzero
  weight of the layer, every nonzero value and product the net forms has a lower bound;
  while every bound stays above ``exp(LOG_TINY)`` (1e-290) no term is lost and every
  marginal keeps full relative precision.  When a bound falls below (weights spanning
  hundreds of decades, whose largest terms sit at incompatible nodes) the scaled net
  stops with status 3 and :func:`net_marginals_log` repeats the computation with every
  value kept as a logarithm (several times slower; nothing can underflow).  The caller
  also checks the output (finite, columns summing to 1).
* The number of feasible events is counted by the same net with unit weights (in
  floating point: exact below ``2**53``), rescaled by exact powers of two so that it
  never overflows (``count * 2**exp2``).
* Limits, checked before any work: ``MAX_SLOTS`` frontier elements, ``MAX_CELLS`` stored
  values (the memory), ``MAX_COST`` node visits (the time; ``MAX_LOG_COST`` for the
  log-space net).

The functions here are kernels: :func:`trackcore.association.jpda_marginals` validates
the input and calls them.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

#: largest number of frontier slots (a layer of 2^24 nodes)
MAX_SLOTS = 24
#: largest number of stored forward weights over all layers (8 bytes each: 512 MiB)
MAX_CELLS = 1 << 26
#: cost estimate (node x option visits, a few ns each) above which the net is not attempted
MAX_COST = 1.0e9
#: the same for the log-space net (about 20 ns per visit)
MAX_LOG_COST = 2.5e8
#: log of the smallest value a product of the scaled linear net may take (1e-290, a normal
#: double with a margin); where a layer's bound falls below it the log-space net is used
LOG_TINY = math.log(1e-290)
#: the event counts are rescaled by ``2**-COUNT_SHIFT`` (exactly) above ``2**COUNT_SHIFT``
COUNT_SHIFT = 512

_NEG_INF = -np.inf
_COUNT_BIG = 2.0**COUNT_SHIFT
_COUNT_SMALL = 2.0**-COUNT_SHIFT


@nb.njit(cache=True)
def _find(parent, a):
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


@nb.njit(cache=True)
def _greedy_order(n_p, ptr, idx, n_c):
    """Greedy order of the processed elements ``0..n_p-1`` (adjacency CSR ``ptr, idx``
    into state elements ``0..n_c-1``): returns ``(order, cost, max_live)``."""
    deg_c = np.zeros(n_c, np.int64)
    for e in range(ptr[n_p]):
        deg_c[idx[e]] += 1
    rem = deg_c.copy()
    touched = np.zeros(n_c, np.bool_)
    done = np.zeros(n_p, np.bool_)
    order = np.empty(n_p, np.int64)
    live = 0
    cost = 0.0
    max_live = 0
    for step in range(n_p):
        best = -1
        best_after = 1 << 60
        best_mid = 1 << 60
        for p in range(n_p):
            if done[p]:
                continue
            new = 0
            ret = 0
            for e in range(ptr[p], ptr[p + 1]):
                c = idx[e]
                if not touched[c]:
                    new += 1
                if rem[c] == 1:
                    ret += 1
            after = live + new - ret
            mid = live + new
            if after < best_after or (after == best_after and mid < best_mid):
                best = p
                best_after = after
                best_mid = mid
        done[best] = True
        order[step] = best
        mid = live + 0
        for e in range(ptr[best], ptr[best + 1]):
            c = idx[e]
            if not touched[c]:
                touched[c] = True
                live += 1
        mid = live
        max_live = max(max_live, mid)
        cost += (2.0 ** min(mid, 200)) * (1 + ptr[best + 1] - ptr[best])
        for e in range(ptr[best], ptr[best + 1]):
            c = idx[e]
            rem[c] -= 1
            if rem[c] == 0:
                live -= 1
    return order, cost, max_live


@nb.njit(cache=True)
def _open_layer(valid, side, p, k, slot_o, rem_o, used, top, k_opt, k_ret, opt_ptr, opt_slot,
                opt_j, opt_t, sizes, ret_slot, ret_side, ret_idx):
    """Layer ``k`` processes element ``p`` of ``side`` (0 = target, 1 = measurement): give
    every element ``q`` of the other side that ``p`` can pair with a slot (``slot_o``), list
    the options, then retire the elements whose last pair this was (``rem_o``).  Returns
    ``(top, k_opt, k_ret)``; ``top = -1`` when more than 63 slots would be needed."""
    n_o = valid.shape[0] if side == 0 else valid.shape[1]
    for q in range(n_o):
        if valid[q, p] if side == 0 else valid[p, q]:
            if slot_o[q] < 0:
                s = 0
                while s < 64 and used[s]:
                    s += 1
                if s >= 63:
                    return -1, k_opt, k_ret
                used[s] = True
                slot_o[q] = s
                top = max(top, s + 1)
            opt_slot[k_opt] = slot_o[q]
            opt_j[k_opt] = q if side == 0 else p
            opt_t[k_opt] = p if side == 0 else q
            k_opt += 1
    opt_ptr[k + 1] = k_opt
    sizes[k, 1] = top
    for q in range(n_o):
        if valid[q, p] if side == 0 else valid[p, q]:
            rem_o[q] -= 1
            if rem_o[q] == 0:
                ret_slot[k_ret] = slot_o[q]
                ret_side[k_ret] = 1 - side
                ret_idx[k_ret] = q
                k_ret += 1
                used[slot_o[q]] = False
    return top, k_opt, k_ret


@nb.njit(cache=True)
def _plan(valid):
    """Components, orientation and order of every layer of the net for ``valid`` (m, T).

    Returns ``(layers, options, retire, sizes, cost, isolated)``:

    * ``layers`` (L, 3) int64: processed side (0 = target, 1 = measurement), its index,
      and the slot count of the layer's nodes before it;
    * ``options`` (L + 1 offsets) and arrays ``opt_ptr``, ``opt_slot``, ``opt_j``,
      ``opt_t``: the pairs the processed element can take and the slot of the other end;
    * ``retire`` offsets and arrays ``ret_ptr``, ``ret_slot``, ``ret_side``, ``ret_idx``:
      elements leaving the frontier after the layer;
    * ``sizes`` (L, 2): slots before and after the layer's options (before retirement).
    """
    m, T = valid.shape
    parent = np.arange(m + T)
    n_edges = 0
    for j in range(m):
        for t in range(T):
            if valid[j, t]:
                n_edges += 1
                ra = _find(parent, j)
                rb = _find(parent, m + t)
                if ra != rb:
                    parent[ra] = rb
    root = np.empty(m + T, np.int64)
    for a in range(m + T):
        root[a] = _find(parent, a)
    tdeg = np.zeros(T, np.int64)
    mdeg = np.zeros(m, np.int64)
    for j in range(m):
        for t in range(T):
            if valid[j, t]:
                tdeg[t] += 1
                mdeg[j] += 1
    isolated = tdeg == 0
    # components with at least one edge, in order of their smallest target
    comp_of_root = np.full(m + T, -1, np.int64)
    n_comp = 0
    for t in range(T):
        if tdeg[t] > 0 and comp_of_root[root[m + t]] < 0:
            comp_of_root[root[m + t]] = n_comp
            n_comp += 1
    # members
    c_nt = np.zeros(n_comp, np.int64)
    c_nm = np.zeros(n_comp, np.int64)
    for t in range(T):
        if tdeg[t] > 0:
            c_nt[comp_of_root[root[m + t]]] += 1
    for j in range(m):
        if mdeg[j] > 0:
            c_nm[comp_of_root[root[j]]] += 1
    t_ptr = np.zeros(n_comp + 1, np.int64)
    m_ptr = np.zeros(n_comp + 1, np.int64)
    for c in range(n_comp):
        t_ptr[c + 1] = t_ptr[c] + c_nt[c]
        m_ptr[c + 1] = m_ptr[c] + c_nm[c]
    t_mem = np.empty(t_ptr[n_comp], np.int64)
    m_mem = np.empty(m_ptr[n_comp], np.int64)
    fill_t = t_ptr[:-1].copy()
    fill_m = m_ptr[:-1].copy()
    t_loc = np.full(T, -1, np.int64)
    m_loc = np.full(m, -1, np.int64)
    for t in range(T):
        if tdeg[t] > 0:
            c = comp_of_root[root[m + t]]
            t_loc[t] = fill_t[c] - t_ptr[c]
            t_mem[fill_t[c]] = t
            fill_t[c] += 1
    for j in range(m):
        if mdeg[j] > 0:
            c = comp_of_root[root[j]]
            m_loc[j] = fill_m[c] - m_ptr[c]
            m_mem[fill_m[c]] = j
            fill_m[c] += 1
    L = 0
    total_cost = 0.0
    side = np.empty(n_comp, np.int64)
    orders = np.empty(m + T, np.int64)
    ord_ptr = np.zeros(n_comp + 1, np.int64)
    for c in range(n_comp):
        nt = c_nt[c]
        nm = c_nm[c]
        # A: targets processed, adjacency target -> measurement (local indices)
        pa = np.zeros(nt + 1, np.int64)
        ia = np.empty(n_edges, np.int64)
        for a in range(nt):
            t = t_mem[t_ptr[c] + a]
            k = pa[a]
            for j in range(m):
                if valid[j, t]:
                    ia[k] = m_loc[j]
                    k += 1
            pa[a + 1] = k
        # B: measurements processed, adjacency measurement -> target
        pb = np.zeros(nm + 1, np.int64)
        ib = np.empty(n_edges, np.int64)
        for b in range(nm):
            j = m_mem[m_ptr[c] + b]
            k = pb[b]
            for t in range(T):
                if valid[j, t]:
                    ib[k] = t_loc[t]
                    k += 1
            pb[b + 1] = k
        oa, cost_a, live_a = _greedy_order(nt, pa, ia, nm)
        ob, cost_b, live_b = _greedy_order(nm, pb, ib, nt)
        if cost_a <= cost_b:
            side[c] = 0
            total_cost += cost_a
            n_p = nt
            for s in range(nt):
                orders[L + s] = t_mem[t_ptr[c] + oa[s]]
        else:
            side[c] = 1
            total_cost += cost_b
            n_p = nm
            for s in range(nm):
                orders[L + s] = m_mem[m_ptr[c] + ob[s]]
        L += n_p
        ord_ptr[c + 1] = L
    # layer structure with slot allocation
    layers = np.empty((L, 2), np.int64)
    sizes = np.zeros((L, 2), np.int64)
    opt_ptr = np.zeros(L + 1, np.int64)
    opt_slot = np.empty(n_edges, np.int64)
    opt_j = np.empty(n_edges, np.int64)
    opt_t = np.empty(n_edges, np.int64)
    ret_ptr = np.zeros(L + 1, np.int64)
    ret_slot = np.empty(m + T, np.int64)
    ret_side = np.empty(m + T, np.int64)
    ret_idx = np.empty(m + T, np.int64)
    slot_m = np.full(m, -1, np.int64)
    slot_t = np.full(T, -1, np.int64)
    rem_m = mdeg.copy()
    rem_t = tdeg.copy()
    used = np.zeros(64, np.bool_)
    top = 0           # slots 0..top-1 may be in use
    k_opt = 0
    k_ret = 0
    for c in range(n_comp):
        for k in range(ord_ptr[c], ord_ptr[c + 1]):
            p = orders[k]
            layers[k, 0] = side[c]
            layers[k, 1] = p
            sizes[k, 0] = top
            if side[c] == 0:  # a target: its options are measurements
                top, k_opt, k_ret = _open_layer(valid, 0, p, k, slot_m, rem_m, used, top,
                                                k_opt, k_ret, opt_ptr, opt_slot, opt_j,
                                                opt_t, sizes, ret_slot, ret_side, ret_idx)
            else:  # a measurement: its options are targets
                top, k_opt, k_ret = _open_layer(valid, 1, p, k, slot_t, rem_t, used, top,
                                                k_opt, k_ret, opt_ptr, opt_slot, opt_j,
                                                opt_t, sizes, ret_slot, ret_side, ret_idx)
            if top < 0:  # more than 63 slots at once
                return (layers, sizes, opt_ptr, opt_slot, opt_j, opt_t, ret_ptr, ret_slot,
                        ret_side, ret_idx, np.inf, isolated)
            ret_ptr[k + 1] = k_ret
            while top > 0 and not used[top - 1]:
                top -= 1
    return (layers, sizes, opt_ptr, opt_slot, opt_j, opt_t, ret_ptr, ret_slot, ret_side,
            ret_idx, total_cost, isolated)


@nb.njit(cache=True)
def plan_size(valid, n_count):
    """``(cost, cells, max_slots)`` of the net for ``valid`` with ``n_count`` count levels."""
    (layers, sizes, opt_ptr, opt_slot, opt_j, opt_t, ret_ptr, ret_slot, ret_side, ret_idx,
     cost, isolated) = _plan(valid)
    if cost == np.inf:
        return np.inf, np.inf, 64
    cells = 0.0
    mx = 0
    for k in range(layers.shape[0]):
        cells += (2.0 ** sizes[k, 0]) * n_count
        mx = max(mx, sizes[k, 1])
    return cost * n_count, cells, mx


@nb.njit(cache=True)
def _pull(a_k, s_pre, n_int, D1, o0, o1, opt_slot, opt_w, null_w, out):
    """One layer's options, forward: ``out`` (n_int, D1) from the nodes ``a_k``
    (2^s_pre, D1) before the layer.

    Node ``s2`` after the options is reached from ``s2`` itself (the null option) or from
    ``s2`` minus the bit of the option taken.  For an option whose slot ``c`` is already
    in the frontier the nodes with bit ``c`` set come in contiguous blocks of ``2^c``;
    for a slot entering the frontier (``c >= s_pre``) they are the block ``[2^c, 2^c +
    2^s_pre)``: every loop below runs over contiguous memory.
    """
    n_pre = 1 << s_pre
    for i in range(n_pre * D1):
        out[i] = a_k[i] * null_w
    for i in range(n_pre * D1, n_int * D1):
        out[i] = 0.0
    for o in range(o0, o1):
        w = opt_w[o]
        if w == 0.0:
            continue
        c = opt_slot[o]
        bit = 1 << c
        if c < s_pre:
            starts = range(bit, n_pre, 2 * bit)
            length = bit
        else:
            starts = range(bit, bit + 1)
            length = n_pre
        for st in starts:
            if D1 == 1:
                for s2 in range(st, st + length):
                    out[s2] += a_k[s2 - bit] * w
            else:
                for s2 in range(st, st + length):
                    b2 = s2 * D1
                    b1 = (s2 - bit) * D1
                    for d in range(1, D1):
                        out[b2 + d] += a_k[b1 + d - 1] * w


@nb.njit(cache=True)
def _count_pull(c_k, s_pre, n_int, o0, o1, opt_slot, out):
    """:func:`_pull` for the event counts (unit weights, no count dimension)."""
    n_pre = 1 << s_pre
    for i in range(n_pre):
        out[i] = c_k[i]
    for i in range(n_pre, n_int):
        out[i] = 0.0
    for o in range(o0, o1):
        c = opt_slot[o]
        bit = 1 << c
        if c < s_pre:
            for st in range(bit, n_pre, 2 * bit):
                for s2 in range(st, st + bit):
                    out[s2] += c_k[s2 - bit]
        else:
            for s2 in range(bit, bit + n_pre):
                out[s2] = c_k[s2 - bit]


@nb.njit(cache=True)
def _back(a_k, b_int, s_pre, D1, o0, o1, opt_slot, opt_w, null_w, b_cur, acc_opt):
    """One layer's options, backward: ``b_cur`` (2^s_pre, D1) from the nodes after the
    options ``b_int``; adds ``sum a_k b_int`` over the nodes that can take each option to
    ``acc_opt`` and returns that sum for the null option (weights not yet applied)."""
    n_pre = 1 << s_pre
    acc_n = 0.0
    for i in range(n_pre * D1):
        b_cur[i] = b_int[i] * null_w
        acc_n += a_k[i] * b_int[i]
    for o in range(o0, o1):
        w = opt_w[o]
        c = opt_slot[o]
        bit = 1 << c
        if c < s_pre:
            starts = range(0, n_pre, 2 * bit)
            length = bit
        else:
            starts = range(1)
            length = n_pre
        acc = 0.0
        for st in starts:
            if D1 == 1:
                for s in range(st, st + length):
                    v = b_int[s + bit]
                    b_cur[s] += v * w
                    acc += a_k[s] * v
            else:
                for s in range(st, st + length):
                    b1 = s * D1
                    b2 = (s + bit) * D1
                    for d in range(D1 - 1):
                        v = b_int[b2 + d + 1]
                        b_cur[b1 + d] += v * w
                        acc += a_k[b1 + d] * v
        acc_opt[o] += acc
    return acc_n


@nb.njit(cache=True)
def _retire(src, cnt_src, n_int, D1, r0, r1, ret_slot, ret_v, dst, cnt_dst, n_dst, count):
    """Elements leaving the frontier: node ``s`` moves to ``s`` without their bits, times
    ``1 - P_D`` for every leaving target that was not used (``dst`` is zeroed first)."""
    for i in range(n_dst * D1):
        dst[i] = 0.0
    if count:
        for i in range(n_dst):
            cnt_dst[i] = 0.0
    for s in range(n_int):
        tgt = s
        f = 1.0
        for r in range(r0, r1):
            bit = 1 << ret_slot[r]
            if s & bit:
                tgt ^= bit
            else:
                f *= ret_v[r]
        if count:
            cnt_dst[tgt] += cnt_src[s]
        if f == 0.0:
            continue
        for d in range(D1):
            dst[tgt * D1 + d] += src[s * D1 + d] * f


@nb.njit(cache=True)
def _count_retire(cnt_src, n_int, r0, r1, ret_slot, cnt_dst, n_dst):
    """:func:`_retire` for the event counts alone."""
    for i in range(n_dst):
        cnt_dst[i] = 0.0
    for s in range(n_int):
        tgt = s
        for r in range(r0, r1):
            bit = 1 << ret_slot[r]
            if s & bit:
                tgt ^= bit
        cnt_dst[tgt] += cnt_src[s]


@nb.njit(cache=True)
def _rescale_counts(cnt, n):
    """Multiply ``cnt[:n]`` by ``2**-COUNT_SHIFT`` (exact) once its maximum exceeds
    ``2**COUNT_SHIFT``; returns the power of two taken out (0 or ``COUNT_SHIFT``)."""
    mx = 0.0
    for i in range(n):
        mx = max(mx, cnt[i])
    if mx <= _COUNT_BIG:
        return 0
    for i in range(n):
        cnt[i] *= _COUNT_SMALL
    return COUNT_SHIFT


@nb.njit(cache=True)
def _normalise(x, n):
    """Scale ``x[:n]`` to a maximum of 1; returns the log of the factor (``-inf`` if all
    are 0) and the log of the smallest nonzero value after scaling."""
    mx = 0.0
    for i in range(n):
        mx = max(mx, x[i])
    if mx == 0.0:
        return _NEG_INF, 0.0
    inv = 1.0 / mx
    mn = 1.0
    for i in range(n):
        v = x[i] * inv
        x[i] = v
        if 0.0 < v < mn:
            mn = v
    return math.log(mx), math.log(mn)


@nb.njit(cache=True)
def _limits(valid, D1, marginals, max_cost):
    """The plan and its size: ``(plan..., status, info)`` with ``status`` 1 when a limit
    (``MAX_SLOTS``, ``MAX_CELLS`` if ``marginals``, ``max_cost``) is exceeded and
    ``info = [frontier slots, stored values, cost]``."""
    (layers, sizes, opt_ptr, opt_slot, opt_j, opt_t, ret_ptr, ret_slot, ret_side, ret_idx,
     cost, isolated) = _plan(valid)
    L = layers.shape[0]
    info = np.zeros(3)
    info[2] = cost * D1
    if cost == np.inf:
        info[0] = 64.0
        info[1] = np.inf
        return (layers, sizes, opt_ptr, opt_slot, opt_j, opt_t, ret_ptr, ret_slot, ret_side,
                ret_idx, isolated, 1, info)
    cells = 0.0
    mx = 0
    for k in range(L):
        cells += (2.0 ** sizes[k, 0]) * D1
        mx = max(mx, sizes[k, 1])
    info[0] = mx
    info[1] = cells if marginals else (2.0 ** mx) * D1
    status = 0
    if mx > MAX_SLOTS or info[2] > max_cost or (marginals and cells > MAX_CELLS):
        status = 1
    return (layers, sizes, opt_ptr, opt_slot, opt_j, opt_t, ret_ptr, ret_slot, ret_side,
            ret_idx, isolated, status, info)


@nb.njit(cache=True)
def _layer_weights(logw, log_miss, layers, opt_ptr, opt_j, opt_t, ret_ptr, ret_side, ret_idx):
    """Log weights of every layer's options and null option, scaled so that the largest
    of a layer is 1 (``opt_lw``, ``null_lw``); the log factors of the elements leaving the
    frontier unused (``ret_lv``: ``log(1 - P_D)`` of a target, 0 of a measurement); per
    layer, the log of its smallest nonzero scaled weight (``lo``) and the sum of its
    leaving elements' nonzero log factors (``rv``)."""
    L = layers.shape[0]
    n_opt = opt_ptr[L]
    opt_lw = np.empty(n_opt)
    null_lw = np.empty(L)
    lo = np.zeros(L)
    for k in range(L):
        ln = log_miss[layers[k, 1]] if layers[k, 0] == 0 else 0.0
        mx = ln
        for o in range(opt_ptr[k], opt_ptr[k + 1]):
            mx = max(mx, logw[opt_j[o], opt_t[o]])
        if mx == _NEG_INF:
            mx = 0.0
        null_lw[k] = ln - mx
        mn = null_lw[k] if null_lw[k] > _NEG_INF else 0.0
        for o in range(opt_ptr[k], opt_ptr[k + 1]):
            v = logw[opt_j[o], opt_t[o]] - mx
            opt_lw[o] = v
            if _NEG_INF < v < mn:
                mn = v
        lo[k] = mn
    ret_lv = np.empty(ret_ptr[L])
    rv = np.zeros(L)
    for k in range(L):
        for r in range(ret_ptr[k], ret_ptr[k + 1]):
            ret_lv[r] = log_miss[ret_idx[r]] if ret_side[r] == 0 else 0.0
            if ret_lv[r] > _NEG_INF:
                rv[k] += ret_lv[r]
    return opt_lw, null_lw, ret_lv, lo, rv


@nb.njit(cache=True)
def net_marginals(logw, valid, log_miss, lg_count):
    """Exact JPDA marginals by the hypothesis net in scaled linear arithmetic.

    ``logw`` (m, T): log weight of pair (j, t) *including* ``log P_D^t`` (``-inf`` where
    invalid or zero); ``valid`` (m, T): the validation matrix (structure, for counting);
    ``log_miss`` (T,): ``log(1 - P_D^t)``; ``lg_count`` (D + 1,): log factor of the total
    number of matched pairs ``d = 0..D`` (all zeros of length 1 for the parametric
    form, which then has no count dimension).

    Returns ``(beta (m + 1, T), count, count_exp2, status, info)``: the number of feasible
    events is ``count * 2**count_exp2`` (``count_exp2 = 0`` and ``count`` exact below
    ``2**53``); status 0 = ok, 1 = the net exceeds a limit (``info`` = [frontier slots,
    stored values, cost]), 2 = every event has zero weight, 3 = not certified: some
    product of the scaled weights could fall below ``exp(LOG_TINY)`` (use
    :func:`net_marginals_log`).

    The certificate: every nonzero node value, weight and product formed here is bounded
    below, layer by layer, from the smallest nonzero value actually stored in the layer
    before and the smallest nonzero weight of the layer; when every bound stays above
    ``exp(LOG_TINY)`` no term underflows and every marginal has full relative precision.
    """
    m, T = valid.shape
    beta = np.zeros((m + 1, T))
    D1 = lg_count.shape[0]
    (layers, sizes, opt_ptr, opt_slot, opt_j, opt_t, ret_ptr, ret_slot, ret_side, ret_idx,
     isolated, status, info) = _limits(valid, D1, True, MAX_COST)
    # isolated targets: missed with certainty (weight 1 - P_D, zero if P_D = 1)
    for t in range(T):
        if isolated[t]:
            beta[0, t] = 1.0
            if log_miss[t] == _NEG_INF:
                return beta, 0.0, 0, 2, info
    if status:
        return beta, 0.0, 0, 1, info
    L = layers.shape[0]
    max_int = 0
    for k in range(L):
        max_int = max(max_int, sizes[k, 1])
    opt_lw, null_lw, ret_lv, lo, rv = _layer_weights(logw, log_miss, layers, opt_ptr, opt_j,
                                                     opt_t, ret_ptr, ret_side, ret_idx)
    n_opt = opt_ptr[L]
    opt_w = np.empty(n_opt)
    for o in range(n_opt):
        opt_w[o] = math.exp(opt_lw[o])
    null_w = np.empty(L)
    for k in range(L):
        null_w[k] = math.exp(null_lw[k])
    ret_v = np.empty(ret_ptr[L])
    for r in range(ret_ptr[L]):
        ret_v[r] = math.exp(ret_lv[r])
    # ---------------------------------------------------------------- forward
    # nodes of layer k (before its options) are stored for the backward pass
    off = np.zeros(L + 2, np.int64)
    for k in range(L):
        off[k + 1] = off[k] + (1 << sizes[k, 0]) * D1
    off[L + 1] = off[L] + D1
    alpha = np.zeros(off[L + 1])
    a_scale = np.zeros(L + 1)       # log scale of the stored layer (see ``local``)
    a_min = np.zeros(L + 1)         # log of the smallest nonzero stored value per layer
    # parametric form: scales restart at every connected component (a layer with an
    # empty frontier before it), so that the exponent of ``fac`` below only involves the
    # component's own scales (no cancellation between large sums over other components)
    local = D1 == 1
    n_max = (1 << max_int) * D1
    a_int = np.empty(n_max)
    cnt = np.zeros(1 << max_int)
    cnt_int = np.empty(1 << max_int)
    c_exp = 0
    alpha[0] = 1.0
    cnt[0] = 1.0
    for k in range(L):
        s_pre = sizes[k, 0]
        n_int = 1 << sizes[k, 1]
        n_next = (1 << sizes[k + 1, 0]) if k + 1 < L else 1
        a_k = alpha[off[k]:off[k + 1]]
        a_next = alpha[off[k + 1]:off[k + 2]]
        r0 = ret_ptr[k]
        r1 = ret_ptr[k + 1]
        # every nonzero value formed in this layer is at least exp(bound) before scaling
        bound = a_min[k] + lo[k] + rv[k]
        if bound < LOG_TINY:
            return beta, 0.0, 0, 3, info
        direct = r0 == r1 and n_int == n_next
        _pull(a_k, s_pre, n_int, D1, opt_ptr[k], opt_ptr[k + 1], opt_slot, opt_w, null_w[k],
              a_next if direct else a_int)
        _count_pull(cnt, s_pre, n_int, opt_ptr[k], opt_ptr[k + 1], opt_slot, cnt_int)
        if direct:
            for i in range(n_next):
                cnt[i] = cnt_int[i]
        else:
            _retire(a_int, cnt_int, n_int, D1, r0, r1, ret_slot, ret_v, a_next, cnt, n_next,
                    True)
        c_exp += _rescale_counts(cnt, n_next)
        ls, lmin = _normalise(a_next, n_next * D1)
        if ls == _NEG_INF:
            return beta, 0.0, 0, 2, info
        if bound - max(ls, 0.0) < LOG_TINY:
            return beta, 0.0, 0, 3, info
        # per component in the parametric form (D1 = 1: the components are independent)
        a_scale[k + 1] = (0.0 if local and s_pre == 0 else a_scale[k]) + ls
        a_min[k + 1] = lmin
    n_ev = cnt[0]
    # total: sum_d alpha_L[d] g(d)
    gmax = _NEG_INF
    for d in range(D1):
        gmax = max(gmax, lg_count[d])
    g = np.empty(D1)
    g_min = 0.0
    zt = 0.0
    a_L = alpha[off[L]:off[L + 1]]
    for d in range(D1):
        g[d] = math.exp(lg_count[d] - gmax)
        g_min = min(g_min, lg_count[d] - gmax)
        zt += a_L[d] * g[d]
    if a_min[L] + g_min < LOG_TINY:
        return beta, 0.0, 0, 3, info
    if zt == 0.0:
        return beta, n_ev, c_exp, 2, info
    log_z = math.log(zt) + a_scale[L]
    log_zc = log_z
    # ---------------------------------------------------------------- backward
    b_next = np.zeros(n_max)
    b_cur = np.zeros(n_max)
    b_tmp = np.empty(n_max)
    for d in range(D1):
        b_next[d] = g[d]
    b_scale = 0.0
    b_min = g_min
    acc_opt = np.zeros(n_opt)
    acc_null = np.zeros(L)
    acc_ret = np.zeros(ret_ptr[L])
    for k in range(L - 1, -1, -1):
        s_pre = sizes[k, 0]
        n_pre = 1 << s_pre
        n_int = 1 << sizes[k, 1]
        n_next = (1 << sizes[k + 1, 0]) if k + 1 < L else 1
        r0 = ret_ptr[k]
        r1 = ret_ptr[k + 1]
        # nonzero backward values after the retirement are at least exp(b_min + rv[k]);
        # every product with a forward value and a weight at least exp(bound)
        bound = a_min[k] + lo[k] + b_min + rv[k]
        if bound < LOG_TINY:
            return beta, 0.0, 0, 3, info
        if r0 == r1 and n_int == n_next:
            b_int = b_next
        else:
            b_int = b_tmp
            for s in range(n_int):
                tgt = s
                f = 1.0
                for r in range(r0, r1):
                    bit = 1 << ret_slot[r]
                    if s & bit:
                        tgt ^= bit
                    else:
                        f *= ret_v[r]
                for d in range(D1):
                    b_int[s * D1 + d] = f * b_next[tgt * D1 + d]
        if local and (k + 1 == L or sizes[k + 1, 0] == 0):
            # last layer of a component: its total, and the backward scale restarts
            log_zc = log_z if k + 1 == L else a_scale[k + 1]
            b_scale = 0.0
        a_eff = 0.0 if local and s_pre == 0 else a_scale[k]
        fac = math.exp(a_eff + b_scale - log_zc)
        if not fac < np.inf:
            return beta, 0.0, 0, 3, info
        a_k = alpha[off[k]:off[k + 1]]
        # targets leaving the frontier unused (measurements processed): their miss marginal
        has_t = False
        for r in range(r0, r1):
            if ret_side[r] == 0:
                has_t = True
        if has_t:
            _pull(a_k, s_pre, n_int, D1, opt_ptr[k], opt_ptr[k + 1], opt_slot, opt_w,
                  null_w[k], a_int)
            for r in range(r0, r1):
                if ret_side[r] != 0:
                    continue
                bit = 1 << ret_slot[r]
                acc = 0.0
                for st in range(0, n_int, 2 * bit):
                    for i in range(st * D1, (st + bit) * D1):
                        acc += a_int[i] * b_int[i]
                acc_ret[r] = acc * fac
        o0 = opt_ptr[k]
        o1 = opt_ptr[k + 1]
        acc_n = _back(a_k, b_int, s_pre, D1, o0, o1, opt_slot, opt_w, null_w[k], b_cur,
                      acc_opt)
        acc_null[k] = acc_n * null_w[k] * fac
        for o in range(o0, o1):
            acc_opt[o] *= opt_w[o] * fac
        ls, lmin = _normalise(b_cur, n_pre * D1)
        if ls == _NEG_INF:
            for i in range(n_pre * D1):
                b_next[i] = 0.0
        else:
            if b_min + rv[k] + lo[k] - max(ls, 0.0) < LOG_TINY:
                return beta, 0.0, 0, 3, info
            for i in range(n_pre * D1):
                b_next[i] = b_cur[i]
            b_scale += ls
            b_min = lmin
    # ---------------------------------------------------------------- outputs
    for o in range(n_opt):
        beta[opt_j[o] + 1, opt_t[o]] = acc_opt[o]
    for k in range(L):
        if layers[k, 0] == 0:
            beta[0, layers[k, 1]] = acc_null[k]
    for r in range(ret_ptr[L]):
        if ret_side[r] == 0:
            beta[0, ret_idx[r]] = acc_ret[r]
    return beta, n_ev, c_exp, 0, info


# ------------------------------------------------------------------- log-space net
@nb.njit(cache=True)
def _lae(x, y):
    """``log(exp(x) + exp(y))``, ``-inf`` safe."""
    if x == _NEG_INF:
        return y
    if y == _NEG_INF:
        return x
    if x >= y:
        return x + math.log1p(math.exp(y - x))
    return y + math.log1p(math.exp(x - y))


@nb.njit(cache=True)
def _pull_log(a_k, s_pre, n_int, D1, o0, o1, opt_slot, opt_lw, null_lw, out):
    """:func:`_pull` on log values."""
    n_pre = 1 << s_pre
    for i in range(n_pre * D1):
        out[i] = a_k[i] + null_lw
    for i in range(n_pre * D1, n_int * D1):
        out[i] = _NEG_INF
    for o in range(o0, o1):
        lw = opt_lw[o]
        if lw == _NEG_INF:
            continue
        c = opt_slot[o]
        bit = 1 << c
        if c < s_pre:
            starts = range(bit, n_pre, 2 * bit)
            length = bit
        else:
            starts = range(bit, bit + 1)
            length = n_pre
        for st in starts:
            for s2 in range(st, st + length):
                b2 = s2 * D1
                b1 = (s2 - bit) * D1
                if D1 == 1:
                    out[b2] = _lae(out[b2], a_k[b1] + lw)
                else:
                    for d in range(1, D1):
                        out[b2 + d] = _lae(out[b2 + d], a_k[b1 + d - 1] + lw)


@nb.njit(cache=True)
def _back_log(a_k, b_int, s_pre, D1, o0, o1, opt_slot, opt_lw, null_lw, b_cur, acc_opt):
    """:func:`_back` on log values (``acc_opt[o]`` is set, not added to)."""
    n_pre = 1 << s_pre
    acc_n = _NEG_INF
    for i in range(n_pre * D1):
        b_cur[i] = b_int[i] + null_lw
        acc_n = _lae(acc_n, a_k[i] + b_int[i])
    for o in range(o0, o1):
        lw = opt_lw[o]
        c = opt_slot[o]
        bit = 1 << c
        if c < s_pre:
            starts = range(0, n_pre, 2 * bit)
            length = bit
        else:
            starts = range(1)
            length = n_pre
        acc = _NEG_INF
        for st in starts:
            for s in range(st, st + length):
                b1 = s * D1
                b2 = (s + bit) * D1
                if D1 == 1:
                    v = b_int[b2]
                    b_cur[b1] = _lae(b_cur[b1], v + lw)
                    acc = _lae(acc, a_k[b1] + v)
                else:
                    for d in range(D1 - 1):
                        v = b_int[b2 + d + 1]
                        b_cur[b1 + d] = _lae(b_cur[b1 + d], v + lw)
                        acc = _lae(acc, a_k[b1 + d] + v)
        acc_opt[o] = acc
    return acc_n


@nb.njit(cache=True)
def _retire_log(src, n_int, D1, r0, r1, ret_slot, ret_lv, dst, n_dst):
    """:func:`_retire` on log values."""
    for i in range(n_dst * D1):
        dst[i] = _NEG_INF
    for s in range(n_int):
        tgt = s
        lf = 0.0
        for r in range(r0, r1):
            bit = 1 << ret_slot[r]
            if s & bit:
                tgt ^= bit
            else:
                lf += ret_lv[r]
        if lf == _NEG_INF:
            continue
        for d in range(D1):
            dst[tgt * D1 + d] = _lae(dst[tgt * D1 + d], src[s * D1 + d] + lf)


@nb.njit(cache=True)
def _shift_log(x, n):
    """Subtract the maximum of ``x[:n]`` (returned; ``-inf`` if every value is)."""
    mx = _NEG_INF
    for i in range(n):
        mx = max(mx, x[i])
    if mx == _NEG_INF:
        return mx
    for i in range(n):
        x[i] -= mx
    return mx


@nb.njit(cache=True)
def net_marginals_log(logw, valid, log_miss, lg_count):
    """:func:`net_marginals` with every node value, weight and sum kept as a logarithm
    (each layer shifted to a maximum of 0): nothing underflows, at the cost of an
    exponential and a logarithm per operation.  Returns ``(beta, status, info)``."""
    m, T = valid.shape
    beta = np.zeros((m + 1, T))
    D1 = lg_count.shape[0]
    (layers, sizes, opt_ptr, opt_slot, opt_j, opt_t, ret_ptr, ret_slot, ret_side, ret_idx,
     isolated, status, info) = _limits(valid, D1, True, MAX_LOG_COST)
    for t in range(T):
        if isolated[t]:
            beta[0, t] = 1.0
            if log_miss[t] == _NEG_INF:
                return beta, 2, info
    if status:
        return beta, 1, info
    L = layers.shape[0]
    max_int = 0
    for k in range(L):
        max_int = max(max_int, sizes[k, 1])
    opt_lw, null_lw, ret_lv, lo, rv = _layer_weights(logw, log_miss, layers, opt_ptr, opt_j,
                                                     opt_t, ret_ptr, ret_side, ret_idx)
    n_opt = opt_ptr[L]
    # ---------------------------------------------------------------- forward
    off = np.zeros(L + 2, np.int64)
    for k in range(L):
        off[k + 1] = off[k] + (1 << sizes[k, 0]) * D1
    off[L + 1] = off[L] + D1
    alpha = np.full(off[L + 1], _NEG_INF)
    a_scale = np.zeros(L + 1)
    local = D1 == 1                 # scales per component (see net_marginals)
    n_max = (1 << max_int) * D1
    a_int = np.empty(n_max)
    alpha[0] = 0.0
    for k in range(L):
        s_pre = sizes[k, 0]
        n_int = 1 << sizes[k, 1]
        n_next = (1 << sizes[k + 1, 0]) if k + 1 < L else 1
        a_k = alpha[off[k]:off[k + 1]]
        a_next = alpha[off[k + 1]:off[k + 2]]
        r0 = ret_ptr[k]
        r1 = ret_ptr[k + 1]
        direct = r0 == r1 and n_int == n_next
        _pull_log(a_k, s_pre, n_int, D1, opt_ptr[k], opt_ptr[k + 1], opt_slot, opt_lw,
                  null_lw[k], a_next if direct else a_int)
        if not direct:
            _retire_log(a_int, n_int, D1, r0, r1, ret_slot, ret_lv, a_next, n_next)
        ls = _shift_log(a_next, n_next * D1)
        if ls == _NEG_INF:
            return beta, 2, info
        a_scale[k + 1] = (0.0 if local and s_pre == 0 else a_scale[k]) + ls
    gmax = _NEG_INF
    for d in range(D1):
        gmax = max(gmax, lg_count[d])
    g = np.empty(D1)
    zt = _NEG_INF
    a_L = alpha[off[L]:off[L + 1]]
    for d in range(D1):
        g[d] = lg_count[d] - gmax
        zt = _lae(zt, a_L[d] + g[d])
    if zt == _NEG_INF:
        return beta, 2, info
    log_z = zt + a_scale[L]
    log_zc = log_z
    # ---------------------------------------------------------------- backward
    b_next = np.full(n_max, _NEG_INF)
    b_cur = np.full(n_max, _NEG_INF)
    b_tmp = np.empty(n_max)
    for d in range(D1):
        b_next[d] = g[d]
    b_scale = 0.0
    acc_opt = np.full(n_opt, _NEG_INF)
    acc_null = np.full(L, _NEG_INF)
    acc_ret = np.full(ret_ptr[L], _NEG_INF)
    for k in range(L - 1, -1, -1):
        s_pre = sizes[k, 0]
        n_pre = 1 << s_pre
        n_int = 1 << sizes[k, 1]
        n_next = (1 << sizes[k + 1, 0]) if k + 1 < L else 1
        r0 = ret_ptr[k]
        r1 = ret_ptr[k + 1]
        if r0 == r1 and n_int == n_next:
            b_int = b_next
        else:
            b_int = b_tmp
            for s in range(n_int):
                tgt = s
                lf = 0.0
                for r in range(r0, r1):
                    bit = 1 << ret_slot[r]
                    if s & bit:
                        tgt ^= bit
                    else:
                        lf += ret_lv[r]
                for d in range(D1):
                    b_int[s * D1 + d] = lf + b_next[tgt * D1 + d]
        if local and (k + 1 == L or sizes[k + 1, 0] == 0):
            log_zc = log_z if k + 1 == L else a_scale[k + 1]
            b_scale = 0.0
        lfac = (0.0 if local and s_pre == 0 else a_scale[k]) + b_scale - log_zc
        a_k = alpha[off[k]:off[k + 1]]
        has_t = False
        for r in range(r0, r1):
            if ret_side[r] == 0:
                has_t = True
        if has_t:
            _pull_log(a_k, s_pre, n_int, D1, opt_ptr[k], opt_ptr[k + 1], opt_slot, opt_lw,
                      null_lw[k], a_int)
            for r in range(r0, r1):
                if ret_side[r] != 0:
                    continue
                bit = 1 << ret_slot[r]
                acc = _NEG_INF
                for st in range(0, n_int, 2 * bit):
                    for i in range(st * D1, (st + bit) * D1):
                        acc = _lae(acc, a_int[i] + b_int[i])
                acc_ret[r] = acc + lfac
        o0 = opt_ptr[k]
        o1 = opt_ptr[k + 1]
        acc_n = _back_log(a_k, b_int, s_pre, D1, o0, o1, opt_slot, opt_lw, null_lw[k], b_cur,
                          acc_opt)
        acc_null[k] = acc_n + null_lw[k] + lfac
        for o in range(o0, o1):
            acc_opt[o] += opt_lw[o] + lfac
        ls = _shift_log(b_cur, n_pre * D1)
        for i in range(n_pre * D1):
            b_next[i] = b_cur[i]
        if ls > _NEG_INF:
            b_scale += ls
    # ---------------------------------------------------------------- outputs
    for o in range(n_opt):
        beta[opt_j[o] + 1, opt_t[o]] = math.exp(acc_opt[o])
    for k in range(L):
        if layers[k, 0] == 0:
            beta[0, layers[k, 1]] = math.exp(acc_null[k])
    for r in range(ret_ptr[L]):
        if ret_side[r] == 0:
            beta[0, ret_idx[r]] = math.exp(acc_ret[r])
    return beta, 0, info


@nb.njit(cache=True)
def net_count(valid):
    """``(count, count_exp2, status, info)``: the number of feasible events of ``valid``,
    ``count * 2**count_exp2``, counted by the net with unit weights (``count_exp2 = 0``
    and ``count`` exact below ``2**53``); status 1 (and ``info`` as in
    :func:`net_marginals`) when the net exceeds a limit."""
    (layers, sizes, opt_ptr, opt_slot, opt_j, opt_t, ret_ptr, ret_slot, ret_side, ret_idx,
     isolated, status, info) = _limits(valid, 1, False, MAX_COST)
    if status:
        return 0.0, 0, 1, info
    L = layers.shape[0]
    max_int = 0
    for k in range(L):
        max_int = max(max_int, sizes[k, 1])
    cnt = np.zeros(1 << max_int)
    cnt_int = np.empty(1 << max_int)
    cnt[0] = 1.0
    c_exp = 0
    for k in range(L):
        s_pre = sizes[k, 0]
        n_int = 1 << sizes[k, 1]
        n_next = (1 << sizes[k + 1, 0]) if k + 1 < L else 1
        _count_pull(cnt, s_pre, n_int, opt_ptr[k], opt_ptr[k + 1], opt_slot, cnt_int)
        _count_retire(cnt_int, n_int, ret_ptr[k], ret_ptr[k + 1], ret_slot, cnt, n_next)
        c_exp += _rescale_counts(cnt, n_next)
    return cnt[0], c_exp, 0, info
