"""One swarm episode: configuration, messages, the decision helper and the tick loop; 3D flights."""
