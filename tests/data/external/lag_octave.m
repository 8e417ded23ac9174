% Toy model for the external-adapter tests: first-order thermal lag as an Octave script.
% tau dy/dt = -y + K u with u held between samples (zero-order hold):
% y(k+1) = a y(k) + (1 - a) K u(k), a = exp(-(t(k+1) - t(k)) / tau).
% K [K/W] and tau [s] are uncertain parameters, y0 [K] can be set manually;
% the defaults below are for stand-alone runs only.
if ~exist('K', 'var'), K = 1.0; end
if ~exist('tau', 'var'), tau = 100.0; end
if ~exist('y0', 'var'), y0 = 0.0; end
if ~exist('time', 'var'), time = (0:10:590)'; end
if ~exist('u', 'var'), u = 20 * (time >= 50); end

a = exp(-diff(time) / tau);
y = zeros(size(time));
y(1) = y0;
for k = 1:numel(time) - 1
  y(k + 1) = a(k) * y(k) + (1 - a(k)) * K * u(k);
end
