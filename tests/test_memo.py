"""manipkit.memo.keep: a bounded table whose oldest entry goes first, against a list model of the same rule."""

import threading

from hypothesis import given
from hypothesis import strategies as st

from manipkit.memo import keep


@given(st.lists(st.tuples(st.integers(0, 9), st.integers()), max_size=60), st.integers(1, 6))
def test_the_table_holds_the_last_distinct_keys_kept_newest_last(puts, limit):
    table, model = {}, []  # model: (key, value) pairs, oldest first, each key once
    for key, value in puts:
        assert keep(table, key, value, limit=limit) == value
        model = [pair for pair in model if pair[0] != key] + [(key, value)]
        model = model[-limit:]
        assert list(table.items()) == model


def test_threads_keeping_at_once_leave_a_bounded_table_and_no_error():
    table, errors = {}, []

    def work(offset):
        try:
            for i in range(20_000):
                keep(table, (offset, i % 300), i, limit=50)
        except Exception as exc:  # noqa: BLE001 - any error is the failure
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors and len(table) <= 50 + len(threads)
