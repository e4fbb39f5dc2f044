"""KUKA RSI streaming: the Ethernet XML exchange, the trajectory as RKorr corrections, the
thesis's PID (Eq. 3.26-3.27), a reference UDP streamer and a simulated controller.

``protocol`` (packets), ``corrections`` (setpoint table -> corrections from the pose at
RSI_ON), ``pid`` (Eq. 3.27), ``streamer`` (``feedopt stream``), ``sim`` (``feedopt rsi-sim``).
"""
