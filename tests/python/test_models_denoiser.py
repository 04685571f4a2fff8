"""Two-stage denoiser: shapes and masks for every history/future length, invariances."""

from __future__ import annotations

import pytest
import torch

from ardy_export.models import layout as L
from ardy_export.models.denoiser import Denoiser, DenoiserConfig, split_goal
from ardy_export.models.graphs import (
    DENOISER_INPUTS,
    DENOISER_MODULE_INPUTS,
    cached_inputs,
    example_denoiser_inputs,
)

torch.set_num_threads(1)
H_MAX, F_MAX = 6, 4


def _denoiser(
    two_stage: bool = True, history_self_only: bool = True, modulation: bool = False
) -> Denoiser:
    torch.manual_seed(0)
    cfg = DenoiserConfig(
        feature_dim=L.FEATURE_SIZE,
        latent_dim=8,
        window_tokens=10,
        max_history_tokens=H_MAX,
        max_future_tokens=F_MAX,
        width=32,
        layers=2,
        heads=2,
        ff_mult=2,
        two_stage=two_stage,
        history_self_only=history_self_only,
        condition_modulation=modulation,
    )
    den = Denoiser(cfg).eval()
    for stage in den.stages:
        if stage.modulation is not None:
            # Trained-looking modulation: it starts at zero, which would hide its effects.
            torch.nn.init.normal_(stage.modulation.proj.weight, std=0.2)
            torch.nn.init.normal_(stage.modulation.proj.bias, std=0.2)
    return den


@pytest.fixture(scope="module")
def den() -> Denoiser:
    return _denoiser()


def _run(den: Denoiser, inputs: tuple[torch.Tensor, ...]) -> torch.Tensor:
    with torch.no_grad():
        return den(*inputs)


def test_input_names_match_forward() -> None:
    import inspect

    params = list(inspect.signature(Denoiser.forward).parameters)[1:]
    assert tuple(params) == DENOISER_MODULE_INPUTS
    cached = list(inspect.signature(Denoiser.forward_cached).parameters)[1:]
    assert tuple(cached) == DENOISER_INPUTS


@pytest.mark.parametrize(("two_stage", "modulation"), [(True, False), (False, False), (True, True)])
@pytest.mark.parametrize(("history", "future"), [(0, 0), (1, 0), (3, 2), (H_MAX, F_MAX)])
def test_cached_history_gives_the_uncached_result(
    two_stage: bool, modulation: bool, history: int, future: int
) -> None:
    """forward_cached with history_keys_values and goal_embeddings is forward (the exported
    graphs' split), rows with and without constraints, with and without condition
    modulation (which must leave the history's keys and values alone)."""
    den = _denoiser(two_stage, modulation=modulation)
    inputs = example_denoiser_inputs(den, batch=3, history=history, future=future, seed=history)
    inputs[DENOISER_MODULE_INPUTS.index("constraint_keep")][1] = 0.0  # a row without goals
    with torch.no_grad():
        expected = den(*inputs)
        cached = cached_inputs(den, inputs)
        found = den.forward_cached(*cached)
    keys_values = cached[DENOISER_INPUTS.index("history_kv")]
    cfg = den.config
    stages = 2 if two_stage else 1
    head_dim = cfg.width // cfg.heads
    assert keys_values.shape == (3, stages * cfg.layers, 2, cfg.heads, history, head_dim)
    assert torch.allclose(found, expected, atol=1e-5, rtol=0.0)
    # The keys and values depend on the history only: another step, text and goals give the
    # same ones, and they change when the history changes.
    other = list(example_denoiser_inputs(den, batch=3, history=history, future=future, seed=99))
    other[4], other[5] = inputs[4], inputs[5]
    with torch.no_grad():
        assert torch.equal(cached_inputs(den, tuple(other))[4], keys_values)
    if history:
        with torch.no_grad():
            moved = den.history_keys_values(inputs[4] + 0.5, inputs[5])
        assert not torch.allclose(moved, keys_values)


def test_cached_history_needs_history_self_only() -> None:
    den = _denoiser(history_self_only=False)
    inputs = example_denoiser_inputs(den, batch=1, history=2, future=0)
    with pytest.raises(ValueError, match="history_self_only"):
        den.history_keys_values(inputs[4], inputs[5])


@pytest.mark.parametrize("two_stage", [True, False])
@pytest.mark.parametrize("history", [0, 1, H_MAX])
@pytest.mark.parametrize("future", list(range(F_MAX + 1)))
def test_shapes_for_every_history_and_future_length(
    two_stage: bool, history: int, future: int
) -> None:
    den = _denoiser(two_stage)
    inputs = example_denoiser_inputs(den, batch=3, history=history, future=future)
    out = _run(den, inputs)
    assert out.shape == (3, 10, den.config.token_dim)
    assert torch.isfinite(out).all()


@pytest.mark.parametrize("history", [0, 1, 3])
@pytest.mark.parametrize("future", [0, 1, 3])
def test_padding_does_not_change_the_result(den: Denoiser, history: int, future: int) -> None:
    """A row padded to a longer history (front) and future (back) gives the same x0."""
    x = list(example_denoiser_inputs(den, batch=1, history=history, future=future, seed=3))
    x[5] = torch.ones(1, history)  # all history valid
    x[10] = torch.ones(1, future)
    ref = _run(den, tuple(x))
    ph, pf = H_MAX - history, F_MAX - future
    d, gd = den.config.token_dim, den.config.goal_dim
    padded = list(x)
    padded[4] = torch.cat((torch.randn(1, ph, d) * 5, x[4]), 1)  # garbage in the padding
    padded[5] = torch.cat((torch.zeros(1, ph), x[5]), 1)
    padded[8] = torch.cat((x[8], torch.randn(1, pf, gd)), 1)
    padded[9] = torch.cat((x[9], torch.ones(1, pf, gd)), 1)
    padded[10] = torch.cat((x[10], torch.zeros(1, pf)), 1)
    assert torch.allclose(_run(den, tuple(padded)), ref, atol=1e-5)


def test_batch_rows_are_independent(den: Denoiser) -> None:
    x = example_denoiser_inputs(den, batch=4, history=H_MAX, future=F_MAX, seed=5)
    full = _run(den, x)
    for i in range(4):
        row = tuple(t[i : i + 1] for t in x)
        assert torch.allclose(_run(den, row), full[i : i + 1], atol=1e-5)


def test_drop_flags_remove_text_and_constraints(den: Denoiser) -> None:
    x = list(example_denoiser_inputs(den, batch=2, history=3, future=2, seed=7))
    x[3] = torch.zeros(2)  # text dropped
    x[11] = torch.zeros(2)  # constraints dropped
    ref = _run(den, tuple(x))
    y = list(x)
    y[2] = torch.randn_like(x[2])
    y[6] = torch.randn_like(x[6])
    y[7] = torch.ones_like(x[7])
    y[8] = torch.randn_like(x[8])
    y[9] = torch.ones_like(x[9])
    y[10] = torch.ones_like(x[10])
    assert torch.allclose(_run(den, tuple(y)), ref, atol=1e-6)
    y[3] = torch.ones(2)  # with the text kept, the embedding matters
    assert not torch.allclose(_run(den, tuple(y)), ref, atol=1e-4)


def test_unattended_future_tokens_are_ignored(den: Denoiser) -> None:
    x = list(example_denoiser_inputs(den, batch=1, history=2, future=3, seed=9))
    x[10] = torch.tensor([[1.0, 0.0, 1.0]])
    ref = _run(den, tuple(x))
    y = list(x)
    y[8] = x[8].clone()
    y[8][:, 1] = torch.randn(den.config.goal_dim)
    assert torch.allclose(_run(den, tuple(y)), ref, atol=1e-6)
    y[8][:, 2] += 1.0  # an attended future token changes the result
    assert not torch.allclose(_run(den, tuple(y)), ref, atol=1e-4)


def test_constrained_root_of_x_t_is_overwritten(den: Denoiser) -> None:
    """Where the root is constrained, the noisy root value does not matter."""
    c = den.config
    x = list(example_denoiser_inputs(den, batch=1, history=2, future=0, seed=11))
    mask = torch.zeros(1, c.window_tokens, c.patch, c.feature_dim)
    mask[..., [0, 2]] = 1.0  # dense x, z path over the window
    x[7] = mask.reshape(1, c.window_tokens, c.goal_dim)
    x[6] = torch.randn(1, c.window_tokens, c.goal_dim) * x[7]
    ref = _run(den, tuple(x))
    y = list(x)
    noisy = x[0].clone().reshape(1, c.window_tokens, -1)
    root = noisy[..., : c.root_token_dim].reshape(1, c.window_tokens, c.patch, 5)
    root[..., [0, 2]] += 10.0 * torch.randn(1, c.window_tokens, c.patch, 2)
    noisy[..., : c.root_token_dim] = root.reshape(1, c.window_tokens, -1)
    y[0] = noisy
    assert torch.allclose(_run(den, tuple(y)), ref, atol=1e-6)


def test_split_goal_layout() -> None:
    c = DenoiserConfig(latent_dim=8)
    goal = torch.arange(2 * c.goal_dim, dtype=torch.float32).reshape(1, 2, c.goal_dim)
    root, body = split_goal(goal, c)
    assert root.shape == (1, 2, 20) and body.shape == (1, 2, 4 * 253)
    assert root[0, 1, 5].item() == c.goal_dim + 258  # token 1, frame 1, feature 0
    assert body[0, 0, 253].item() == 258 + 5  # token 0, frame 1, first body feature


def test_stage_one_root_is_detached_before_stage_two() -> None:
    den = _denoiser(two_stage=True).train()
    x = example_denoiser_inputs(den, batch=2, history=2, future=1)
    out = den(*x)
    out[..., den.config.root_token_dim :].sum().backward()  # body loss only
    root_grads = [p.grad for p in den.root_stage.parameters() if p.grad is not None]
    assert all(torch.count_nonzero(g) == 0 for g in root_grads)
    assert any(
        torch.count_nonzero(p.grad) > 0 for p in den.body_stage.parameters() if p.grad is not None
    )


def test_history_attends_only_to_history() -> None:
    """With history_self_only the history tokens' hidden states ignore window, text, goals:
    checked through the layer-1 output of history tokens via a forward hook."""
    den = _denoiser(history_self_only=True)
    seen: list[torch.Tensor] = []
    layer = den.root_stage.transformer.layers[-1]
    handle = layer.register_forward_hook(lambda _m, _i, out: seen.append(out.detach()))
    x = list(example_denoiser_inputs(den, batch=1, history=4, future=2, seed=2))
    x[5] = torch.ones(1, 4)
    _run(den, tuple(x))
    y = list(x)
    y[0], y[1], y[2] = torch.randn_like(x[0]), torch.tensor([0]), torch.randn_like(x[2])
    y[6] = torch.randn_like(x[6])
    _run(den, tuple(y))
    handle.remove()
    hist = slice(2, 6)
    assert torch.allclose(seen[0][:, hist], seen[1][:, hist], atol=1e-6)
    assert not torch.allclose(seen[0][:, 6:], seen[1][:, 6:], atol=1e-3)


@pytest.mark.parametrize("two_stage", [True, False])
def test_a_deeper_denoiser_grown_from_a_trained_one_computes_the_same(two_stage: bool) -> None:
    """load_grown: the trained layers first, the added ones the identity, so the deeper
    model starts from the same outputs; the added layers then train (their output
    projections get gradients)."""
    shallow = _denoiser(two_stage)
    deeper = Denoiser(DenoiserConfig.from_dict({**shallow.config.to_dict(), "layers": 4}))
    assert deeper.load_grown(shallow.state_dict()) == 2
    inputs = example_denoiser_inputs(shallow, batch=2, history=3, future=2, seed=5)
    with torch.no_grad():
        assert torch.allclose(deeper.eval()(*inputs), _run(shallow, inputs), atol=1e-6)
    deeper.train()(*inputs).square().sum().backward()
    added = deeper.stages[0].transformer.layers[3]
    assert float(added.ff[2].weight.grad.abs().sum()) > 0.0
    assert float(added.attn.out.weight.grad.abs().sum()) > 0.0


def test_growing_refuses_a_checkpoint_that_differs_in_more_than_depth() -> None:
    shallow = _denoiser()
    wider = Denoiser(DenoiserConfig.from_dict({**shallow.config.to_dict(), "width": 64}))
    with pytest.raises(RuntimeError, match="size mismatch"):
        wider.load_grown(shallow.state_dict())
    fewer = Denoiser(DenoiserConfig.from_dict({**shallow.config.to_dict(), "layers": 1}))
    with pytest.raises(ValueError, match="2 layers per stage cannot grow to 1"):
        fewer.load_grown(shallow.state_dict())
    joint = Denoiser(DenoiserConfig.from_dict({**shallow.config.to_dict(), "two_stage": False}))
    with pytest.raises(ValueError, match="more than its layer count"):
        joint.load_grown(shallow.state_dict())


def test_modulation_added_to_a_trained_denoiser_starts_at_zero_and_trains() -> None:
    """load_grown into a modulated denoiser: the same outputs as the unmodulated one at
    first; the modulation gets gradients, and once it is not zero the text changes the
    window through it as well as through the text token."""
    plain = _denoiser()
    modulated = Denoiser(
        DenoiserConfig.from_dict({**plain.config.to_dict(), "condition_modulation": True})
    )
    assert modulated.load_grown(plain.state_dict()) == 2
    inputs = example_denoiser_inputs(plain, batch=2, history=3, future=2, seed=7)
    with torch.no_grad():
        assert torch.allclose(modulated.eval()(*inputs), _run(plain, inputs), atol=1e-6)
    modulated.train()(*inputs).square().sum().backward()
    for stage in modulated.stages:
        assert stage.modulation is not None
        assert float(stage.modulation.proj.weight.grad.abs().sum()) > 0.0
    torch.nn.init.normal_(modulated.root_stage.modulation.proj.weight, std=0.2)
    other_text = list(inputs)
    other_text[2] = torch.randn_like(inputs[2])
    with torch.no_grad():
        before = modulated.eval()(*inputs) - plain(*inputs)
        after = modulated(*other_text) - plain(*other_text)
    assert float(before.abs().max()) > 1e-3
    assert not torch.allclose(before, after, atol=1e-4)


def test_lr_scale_trains_named_parameters_at_a_multiple_of_the_learning_rate() -> None:
    """train.lr_scale: the modulation's parameters at 10x, the rest (and the groups'
    weight decay) as without it; a part no parameter has is refused by name."""
    from ardy_export.training.common import TrainSettings, make_optimizer

    den = _denoiser(modulation=True)
    plain_opt, _ = make_optimizer(den, TrainSettings(lr=1e-4))
    assert len(plain_opt.param_groups) == 2
    settings = TrainSettings(lr=1e-4, extra={"lr_scale": {"modulation": 10}})
    opt, _ = make_optimizer(den, settings)
    rates = {id(p): g["initial_lr"] for g in opt.param_groups for p in g["params"]}
    for name, param in den.named_parameters():
        expected = 1e-3 if ".modulation." in name else 1e-4
        assert rates[id(param)] == pytest.approx(expected), name
    assert sum(len(g["params"]) for g in opt.param_groups) == len(list(den.parameters()))
    with pytest.raises(ValueError, match="'no_such_part'"):
        make_optimizer(den, TrainSettings(extra={"lr_scale": {"no_such_part": 2}}))
